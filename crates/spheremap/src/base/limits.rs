//! Every limit an entry point enforces, in one table: the constants the core checks against,
//! the checks themselves, and [`TABLE`], which `spheremap limits`, Python's
//! `spheremap.limits()` and docs/limits.md list (a test keeps the three equal).
//!
//! The CLI, the Python glue and batch recipes all reach the same check in the core, so a value
//! over a limit is refused with the same message whichever of them passed it.

use super::error::{Error, Result};
use serde::Serialize;

/// A map's size N made by any operation (a sphere map's side, a lat-long's height, a cube face).
pub const MAP_SIZE: usize = 1 << 15;
/// A side of an image or texture read from a file, checked against its header.
pub const IMAGE_SIDE: usize = 1 << 16;
/// The pixels (width × height) of an image read from a file, unless `SPHEREMAP_MAX_PIXELS` says
/// otherwise: 2²⁸, 4 GiB as float RGBA.
pub const IMAGE_PIXELS: usize = 1 << 28;
/// A side of a ray-traced photo or preview (`preview`, `Ball.preview`).
pub const CAMERA_SIDE: usize = 1 << 15;
/// A side of a rasterized render (`render`).
pub const RENDER_SIDE: usize = 1 << 14;
/// A size N analysed from a mapping alone (`analyze`): three f64 values per texel, 1.5 GiB at
/// 8192².
pub const ANALYZE_SIZE: usize = 1 << 13;
/// A split-sum table's side (`dfg`), from [`DFG_MIN_SIZE`].
pub const DFG_SIZE: usize = 1 << 12;
/// The smallest split-sum table.
pub const DFG_MIN_SIZE: usize = 2;
/// Samples per output texel of a conversion, a ray-traced map or a MatCap (`samples`,
/// `max_samples`).
pub const SAMPLES: u32 = 1 << 16;
/// Samples per lobe of a sampled prefilter (`lobe_samples`).
pub const LOBE_SAMPLES: usize = 1 << 16;
/// Paths per pixel of a ray-traced preview.
pub const PREVIEW_SAMPLES: u32 = 1 << 12;
/// Frames of a render turntable.
pub const TURNTABLE_FRAMES: u32 = 3600;
/// The size of the demo's maps, from [`DEMO_MIN_SIZE`].
pub const DEMO_SIZE: u32 = 1 << 13;
/// The smallest demo.
pub const DEMO_MIN_SIZE: u32 = 16;
/// The memory a job may need, unless `--max-memory`, `max_memory=` or `SPHEREMAP_MAX_MEMORY`
/// says otherwise: 16 GiB.
pub const MEMORY: u64 = 16 << 30;
/// The bytes a file dropped on the viewer's page may have, unless `--max-upload` says otherwise.
pub const UPLOAD_BYTES: u64 = 512 << 20;
/// The largest vertex coordinate or sphere centre a scene may have (in either sign).
pub const SCENE_COORDINATE: f32 = 1e15;

/// One row of [`TABLE`].
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Limit {
    /// The row's name, as `spheremap limits` and `spheremap.limits()` give it.
    pub name: &'static str,
    /// The largest value accepted (the default, where `env` or an argument can change it).
    pub value: u64,
    /// The smallest accepted.
    pub min: u64,
    /// What is counted: texels, pixels, samples, frames, bytes or units.
    pub unit: &'static str,
    /// What it bounds, and who passes it.
    pub what: &'static str,
    /// The environment variable that replaces the default, if any.
    pub env: Option<&'static str>,
    /// The value in this process, where `env` can replace the default.
    #[serde(skip)]
    pub current: Option<fn() -> u64>,
}

const fn row(name: &'static str, value: u64, unit: &'static str, what: &'static str) -> Limit {
    Limit {
        name,
        value,
        min: 1,
        unit,
        what,
        env: None,
        current: None,
    }
}

/// Every limit, in the order docs/limits.md lists them.
pub const TABLE: [Limit; 15] = [
    row(
        "map_size",
        MAP_SIZE as u64,
        "texels",
        "a map's size N made by any operation: the sphere map's side, the lat-long's height, the cube face (--size, size=)",
    ),
    row(
        "image_side",
        IMAGE_SIDE as u64,
        "pixels",
        "a side of an image or texture read from a file, checked against its header before anything is allocated",
    ),
    Limit {
        env: Some("SPHEREMAP_MAX_PIXELS"),
        current: Some(|| max_pixels() as u64),
        ..row(
            "image_pixels",
            IMAGE_PIXELS as u64,
            "pixels",
            "the pixels of an image read from a file (read_image's max_pixels= too)",
        )
    },
    row(
        "camera_side",
        CAMERA_SIDE as u64,
        "pixels",
        "a side of a ray-traced photo or preview (preview --size, Ball.preview size=)",
    ),
    row(
        "render_side",
        RENDER_SIDE as u64,
        "pixels",
        "a side of a rasterized render (render --size, size=)",
    ),
    row(
        "analyze_size",
        ANALYZE_SIZE as u64,
        "texels",
        "the size N of a mapping analysed on its own (analyze --size, size=)",
    ),
    Limit {
        min: DFG_MIN_SIZE as u64,
        ..row(
            "dfg_size",
            DFG_SIZE as u64,
            "texels",
            "the split-sum table's side (dfg --size, size=)",
        )
    },
    row(
        "samples",
        SAMPLES as u64,
        "samples",
        "samples per output texel of a conversion, a ray-traced map or a bake (--samples, --max-samples)",
    ),
    row(
        "lobe_samples",
        LOBE_SAMPLES as u64,
        "samples",
        "samples per lobe of a sampled prefilter (--lobe-samples)",
    ),
    row(
        "preview_samples",
        PREVIEW_SAMPLES as u64,
        "samples",
        "paths per pixel of a ray-traced preview (preview --samples)",
    ),
    row(
        "turntable_frames",
        TURNTABLE_FRAMES as u64,
        "frames",
        "frames of a render turntable (render --turntable)",
    ),
    Limit {
        min: DEMO_MIN_SIZE as u64,
        ..row(
            "demo_size",
            DEMO_SIZE as u64,
            "texels",
            "the demo's map size (demo --size)",
        )
    },
    Limit {
        env: Some("SPHEREMAP_MAX_MEMORY"),
        current: Some(default_max_memory),
        ..row(
            "memory",
            MEMORY,
            "bytes",
            "the memory a job may need, estimated before it starts (--max-memory, max_memory=)",
        )
    },
    row(
        "upload_bytes",
        UPLOAD_BYTES,
        "bytes",
        "a file dropped on the viewer's page (view --max-upload, max_upload=)",
    ),
    Limit {
        min: 0,
        ..row(
            "scene_coordinate",
            1_000_000_000_000_000,
            "units",
            "the magnitude of a scene's vertex coordinates and sphere centres (generate, preview)",
        )
    },
];

/// The table with the defaults that the environment replaces (`SPHEREMAP_MAX_PIXELS`,
/// `SPHEREMAP_MAX_MEMORY`) as they are in this process.
pub fn table() -> Vec<Limit> {
    TABLE
        .iter()
        .map(|l| Limit {
            value: l.current.map_or(l.value, |f| f()),
            ..*l
        })
        .collect()
}

/// `value` checked against `min..=max` for the argument `what`: the one message every range
/// check gives ("samples: 0 is out of range 1..=65536").
pub fn check_range<T>(what: &str, value: T, min: T, max: T) -> Result<T>
where
    T: PartialOrd + std::fmt::Display + Copy,
{
    if value < min || value > max {
        return Err(Error::param(
            what,
            format!("{value} is out of range {min}..={max}"),
        ));
    }
    Ok(value)
}

/// `n` as a map size for the argument `what` (1..=[`MAP_SIZE`]), or an error naming it.
pub fn check_map_size(what: &str, n: usize) -> Result<usize> {
    check_range(what, n, 1, MAP_SIZE)
}

/// `samples` and `max_samples` (samples per output texel) against 1..=[`SAMPLES`].
pub fn check_samples(samples: u32, max_samples: u32) -> Result<()> {
    check_range("samples", samples, 1, SAMPLES)?;
    check_range("max_samples", max_samples, 1, SAMPLES)?;
    Ok(())
}

/// An image of `width` × `height` whose sides may be 1..=`max` (the argument is `size`).
pub fn check_sides(width: usize, height: usize, max: usize) -> Result<()> {
    if !(1..=max).contains(&width) || !(1..=max).contains(&height) {
        return Err(Error::param(
            "size",
            format!("{width}x{height}: each side must be 1..={max}"),
        ));
    }
    Ok(())
}

/// The pixel limit for images read from files: `SPHEREMAP_MAX_PIXELS` (a pixel count) or
/// [`IMAGE_PIXELS`].
pub fn max_pixels() -> usize {
    std::env::var("SPHEREMAP_MAX_PIXELS")
        .ok()
        .and_then(|s| s.trim().parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or(IMAGE_PIXELS)
}

/// The memory a job may allocate unless told otherwise: `SPHEREMAP_MAX_MEMORY` (bytes, or with
/// a K/M/G/T suffix, powers of 1024) or else [`MEMORY`].
pub fn default_max_memory() -> u64 {
    std::env::var("SPHEREMAP_MAX_MEMORY")
        .ok()
        .and_then(|s| parse_bytes(&s))
        .unwrap_or(MEMORY)
}

/// A memory limit as users write it ("8G", "512M", bytes); the error names `what`.
pub fn parse_memory_limit(what: &str, text: &str) -> Result<u64> {
    parse_bytes(text).ok_or_else(|| {
        Error::param(
            what,
            format!("cannot read {text:?}; expected bytes or a size like 512M, 8G"),
        )
    })
}

/// "8G", "512M", "1000000" → bytes.
pub fn parse_bytes(s: &str) -> Option<u64> {
    let s = s.trim();
    let (num, shift) = match s.char_indices().last()? {
        (i, 'k' | 'K') => (&s[..i], 10),
        (i, 'm' | 'M') => (&s[..i], 20),
        (i, 'g' | 'G') => (&s[..i], 30),
        (i, 't' | 'T') => (&s[..i], 40),
        _ => (s, 0),
    };
    let v: f64 = num.trim().parse().ok()?;
    (v.is_finite() && v >= 0.0 && v * 2f64.powi(shift) < 1.8e19)
        .then(|| (v * 2f64.powi(shift)) as u64)
}

/// Refuses a job whose estimated allocation `bytes` is over `cap`.
pub fn check_memory(what: &str, bytes: u128, cap: u64) -> Result<()> {
    if bytes > cap as u128 {
        let gib = |b: f64| b / (1u64 << 30) as f64;
        return Err(Error::limit(
            what,
            format!(
                "the job needs about {:.1} GiB, over the memory limit of {:.1} GiB \
                 (--max-memory / max_memory= / SPHEREMAP_MAX_MEMORY raise it)",
                gib(bytes as f64),
                gib(cap as f64)
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_holds_the_constants() {
        let v = |name: &str| TABLE.iter().find(|l| l.name == name).unwrap().value;
        assert_eq!(v("map_size"), 32768);
        assert_eq!(v("image_side"), 65536);
        assert_eq!(v("image_pixels"), 1 << 28);
        assert_eq!(v("samples"), 65536);
        assert_eq!(v("memory"), 16 << 30);
        assert_eq!(v("scene_coordinate") as f32, SCENE_COORDINATE);
        let mut names: Vec<_> = TABLE.iter().map(|l| l.name).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), TABLE.len(), "a name twice");
    }

    #[test]
    fn one_message_for_every_range() {
        let e = check_map_size("size", 32769).unwrap_err().to_string();
        assert_eq!(e, "size: 32769 is out of range 1..=32768");
        assert_eq!(check_map_size("size", 32768).unwrap(), 32768);
        let e = check_range("samples", 0u32, 1, SAMPLES)
            .unwrap_err()
            .to_string();
        assert_eq!(e, "samples: 0 is out of range 1..=65536");
    }

    #[test]
    fn bytes_as_users_write_them() {
        assert_eq!(parse_bytes("8G"), Some(8 << 30));
        assert_eq!(parse_bytes("512m"), Some(512 << 20));
        assert_eq!(parse_bytes("1000"), Some(1000));
        assert_eq!(parse_bytes("-1"), None);
        assert_eq!(parse_bytes("lots"), None);
    }
}
