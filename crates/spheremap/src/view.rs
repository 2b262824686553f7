//! What the interactive viewer (`spheremap view`, Python `spheremap.view`) shows, as data a
//! browser uploads to WebGL2 without decoding anything: the rules for turning a mesh, an
//! environment map and a MatCap into those payloads live here, once; the HTTP server is an
//! edge (`crates/spheremap-view`) that only serves them.
//!
//! ## Payloads (all little-endian)
//!
//! * **mesh** (`data/mesh.bin`): `vertices × 3` f32 positions, then `vertices × 3` f32 unit
//!   normals (the file's, else angle-weighted ones, as `render` uses), then `triangles × 3` u32
//!   indices.
//! * **env** (`data/env.bin`): the environment as a **world-frame lat-long** in the default
//!   preset (`blender`: u = ½ + atan2(z, x)/2π, v = acos(y)/π, row 0 at the top), converted from
//!   whatever mapping and view the file holds with the footprint-filtered resampler, RGBA
//!   half floats, with its 2×2 box mip chain, level 0 first ([`ViewTexture::levels`] gives each
//!   level's size and byte offset). The page makes the sphere map of its current camera from it
//!   every frame.
//! * **matcap** (`data/matcap.bin`): the MatCap image as it is (row 0 at the top), RGBA half
//!   floats, one level — sampled bilinearly with clamp-to-edge, as `render --mode matcap` does.
//!
//! Half floats hold up to 65504: brighter texels are clamped, and the count is reported
//! ([`ViewTexture::clamped`]).
//!
//! [`SceneInfo`] (`data/scene.json`) describes the payloads and carries the rules the page
//! must share with `render`: the GLSL snippets of [`crate::jobs::shader`], the tone-map
//! operators, the render modes and MatCap variants, the heat map's colour stops, the mesh's
//! bounding sphere from which `render` frames its default camera.

use crate::base::error::{Error, Result};
use crate::images::codec::{self, ReadOptions};
use crate::images::envmap::{read_env_layout, read_note, EnvFiles};
use crate::images::Image;
use crate::jobs::render::ModeName;
use crate::jobs::source::EnvRequest;
use crate::mappings::mapping::Mapping;
use crate::mappings::matcap::MatcapVariant;
use crate::mesh::Mesh;
use crate::resample::{EnvMap, ResampleOptions};
use std::path::Path;

/// The widest lat-long the viewer sends to the browser (its height is half).
pub const ENV_MAX_WIDTH: usize = 2048;
/// The narrowest.
pub const ENV_MIN_WIDTH: usize = 64;
/// The file kinds a user may drop on the page (by extension, lower case).
pub const ENV_EXTENSIONS: [&str; 9] = [
    "exr", "hdr", "pfm", "png", "jpg", "jpeg", "webp", "ktx2", "dds",
];
pub const MESH_EXTENSIONS: [&str; 3] = ["obj", "glb", "gltf"];
/// The URL parameters of the page (a contract: links and tests set them).
pub const URL_PARAMS: [&str; 13] = [
    "mode",
    "eye",
    "target",
    "up",
    "fovy",
    "size",
    "exposure",
    "tonemap",
    "variant",
    "freeze",
    "smsize",
    "background",
    "normalize",
];
/// The largest half float.
const HALF_MAX: f32 = 65504.0;

/// A texture payload's description.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ViewTexture {
    /// What the user gave (a file name, or the bundled data's name).
    pub name: String,
    /// The mapping the file held (for the environment; the payload is always a lat-long).
    pub mapping: String,
    /// The file's own size.
    pub source_width: usize,
    pub source_height: usize,
    /// Mip levels, level 0 first: (width, height, byte offset in the payload).
    pub levels: Vec<(usize, usize, usize)>,
    /// Texels whose value was over the half-float range and clamped to 65504.
    pub clamped: usize,
    /// A notice from reading the file (a guessed mapping, …).
    pub notice: Option<String>,
}

/// The mesh payload's description.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ViewMesh {
    pub name: String,
    pub vertices: usize,
    pub triangles: usize,
    pub normals_from_file: bool,
    /// The bounding box's centre and half its diagonal: `render` frames its default camera
    /// from them (eye on +Z at 1.1 r / sin(half the smaller field of view); near and far from
    /// the eye's distance d: max(0.9 (d − r), d/1000) and 1.1 (d + r)).
    pub centre: [f64; 3],
    pub radius: f64,
}

/// The GLSL the page compiles: the tested snippets of [`crate::jobs::shader`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ViewGlsl {
    pub texgen: &'static str,
    pub lookup: &'static str,
    pub matcap: &'static str,
}

/// `data/scene.json`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SceneInfo {
    /// Grows each time the data changes (a dropped file): the page refetches.
    pub version: u64,
    pub mesh: ViewMesh,
    pub env: Option<ViewTexture>,
    pub matcap: Option<ViewTexture>,
    pub glsl: ViewGlsl,
    pub modes: [&'static str; 5],
    pub variants: [&'static str; 3],
    pub tonemaps: [&'static str; 3],
    pub url_params: [&'static str; 13],
    /// The heat map's colour stops (sRGB), evenly spaced from 0 to `heat_max_deg`.
    pub heat_stops: [[f32; 3]; 6],
    pub heat_max_deg: f64,
    pub env_extensions: [&'static str; 9],
    pub mesh_extensions: [&'static str; 3],
    /// False in an export (`--export`): no server to take dropped files.
    pub uploads: bool,
}

/// Everything the viewer serves besides its page.
#[derive(Clone, Debug)]
pub struct ViewData {
    pub scene: SceneInfo,
    pub mesh: Vec<u8>,
    pub env: Option<Vec<u8>>,
    pub matcap: Option<Vec<u8>>,
}

/// The heat map's stops in sRGB (those of [`crate::jobs::render::heat_colour`]).
fn heat_stops() -> [[f32; 3]; 6] {
    std::array::from_fn(|i| {
        crate::jobs::render::heat_colour(i as f32 / 5.0).map(codec::linear_to_srgb)
    })
}

impl ViewData {
    /// The viewer's data: `mesh` (default: the bundled teapot), `env` read by `env_req`
    /// (default, when neither an environment nor a MatCap is given: the bundled HDRI),
    /// `matcap`.
    pub fn load(
        mesh: Option<&Path>,
        env: Option<&str>,
        env_req: &EnvRequest,
        matcap: Option<&Path>,
    ) -> Result<ViewData> {
        let m = match mesh {
            Some(p) => (crate::mesh::load_mesh(p)?, display_name(p)),
            None => (crate::demo::teapot()?, "teapot.obj (bundled)".to_string()),
        };
        let mut data = ViewData {
            scene: SceneInfo {
                version: 1,
                mesh: mesh_info(&m.0, m.1),
                env: None,
                matcap: None,
                glsl: ViewGlsl {
                    texgen: crate::jobs::shader::snippet("glsl", "texgen")?,
                    lookup: crate::jobs::shader::snippet("glsl", "lookup")?,
                    matcap: crate::jobs::shader::snippet("glsl", "matcap")?,
                },
                modes: ModeName::NAMES,
                variants: MatcapVariant::NAMES,
                tonemaps: crate::images::tonemap::ToneMap::NAMES,
                url_params: URL_PARAMS,
                heat_stops: heat_stops(),
                heat_max_deg: 5.0,
                env_extensions: ENV_EXTENSIONS,
                mesh_extensions: MESH_EXTENSIONS,
                uploads: true,
            },
            mesh: mesh_bytes(&m.0),
            env: None,
            matcap: None,
        };
        match env {
            Some(e) => data.set_env_file(e, &display_name(Path::new(e)), env_req)?,
            None if matcap.is_none() => {
                let img = crate::demo::apartment()?;
                let latlong = Mapping::parse("latlong", None)?;
                let (info, bytes) = env_payload(
                    &img,
                    latlong,
                    crate::frame::view::IDENTITY,
                    "apartment.exr (bundled)",
                    None,
                )?;
                data.scene.env = Some(info);
                data.env = Some(bytes);
            }
            None => {}
        }
        if let Some(p) = matcap {
            data.set_matcap_file(p, &display_name(p))?;
        }
        // Version 1 is what was loaded; each later replacement counts up from it.
        data.scene.version = 1;
        Ok(data)
    }

    /// Replaces the mesh with the file at `path` (shown as `name`).
    pub fn set_mesh_file(&mut self, path: &Path, name: &str) -> Result<()> {
        let mesh = crate::mesh::load_mesh(path)?;
        self.scene.mesh = mesh_info(&mesh, name.to_string());
        self.mesh = mesh_bytes(&mesh);
        self.scene.version += 1;
        Ok(())
    }

    /// Replaces the environment with the map at `path` (one image or a face pattern), read by
    /// `req` as every lighting job reads its environment.
    pub fn set_env_file(&mut self, path: &str, name: &str, req: &EnvRequest) -> Result<()> {
        let files = EnvFiles::parse(path);
        let note = read_note(files.first())?;
        let r = req.resolve(note.as_ref(), path)?;
        let (mut img, _) = read_env_layout(&files, r.mapping, r.layout, &ReadOptions::default())?;
        codec::check_nonfinite(&mut img, r.nonfinite, files.first())?;
        let (info, bytes) = env_payload(&img, r.mapping, r.world_to_env, name, r.notice)?;
        self.scene.env = Some(info);
        self.env = Some(bytes);
        self.scene.version += 1;
        Ok(())
    }

    /// Replaces the MatCap with the image at `path`.
    pub fn set_matcap_file(&mut self, path: &Path, name: &str) -> Result<()> {
        let img = codec::read_image(path, &ReadOptions::default())?;
        if let Some((x, y, _)) = codec::find_nonfinite(&img) {
            return Err(Error::data(
                path.display().to_string(),
                format!("a MatCap must be finite; texel ({x}, {y}) is not"),
            ));
        }
        let (bytes, clamped) = half_rgba(&img);
        self.scene.matcap = Some(ViewTexture {
            name: name.to_string(),
            mapping: "matcap".into(),
            source_width: img.width,
            source_height: img.height,
            levels: vec![(img.width, img.height, 0)],
            clamped,
            notice: None,
        });
        self.matcap = Some(bytes);
        self.scene.version += 1;
        Ok(())
    }
}

/// The name a file is shown by: its file name.
pub fn display_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}

fn mesh_info(m: &Mesh, name: String) -> ViewMesh {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &m.positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k] as f64);
            hi[k] = hi[k].max(p[k] as f64);
        }
    }
    let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let d: f64 = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    ViewMesh {
        name,
        vertices: m.positions.len(),
        triangles: m.triangles.len(),
        normals_from_file: m.normals_from_file,
        centre,
        radius: (0.5 * d).max(1e-9),
    }
}

fn mesh_bytes(m: &Mesh) -> Vec<u8> {
    let mut out = Vec::with_capacity(m.positions.len() * 24 + m.triangles.len() * 12);
    for v in m.positions.iter().chain(&m.normals) {
        for c in v {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    for t in &m.triangles {
        for i in t {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    out
}

/// The lat-long width the viewer sends for a `w`×`h` map: the power of two nearest the map's
/// own resolution (as many texels: √(2wh)), from [`ENV_MIN_WIDTH`] to [`ENV_MAX_WIDTH`].
pub fn env_width(w: usize, h: usize) -> usize {
    let n = (2.0 * w as f64 * h as f64).sqrt();
    let p = 2f64.powf(n.max(1.0).log2().round()) as usize;
    p.clamp(ENV_MIN_WIDTH, ENV_MAX_WIDTH)
}

/// The world-frame lat-long payload of an environment of `mapping` whose frame is reached from
/// the world's by `world_to_env`.
pub fn env_payload(
    img: &Image,
    mapping: Mapping,
    world_to_env: [[f64; 3]; 3],
    name: &str,
    notice: Option<String>,
) -> Result<(ViewTexture, Vec<u8>)> {
    let src = EnvMap::new(mapping, img, name)?;
    let latlong = Mapping::parse("latlong", None)?;
    let (sw, sh) = match mapping {
        Mapping::Cube(_) => (img.width, img.width * 6),
        _ => (img.width, img.height),
    };
    let w = env_width(sw, sh);
    let opts = ResampleOptions {
        rotation: world_to_env,
        ..Default::default()
    };
    let (mut level, _) = crate::resample::resample(&src, latlong, w, w / 2, &opts, None)?;
    let mut levels = Vec::new();
    let mut bytes = Vec::new();
    let mut clamped = 0;
    loop {
        let (b, c) = half_rgba(&level);
        levels.push((level.width, level.height, bytes.len()));
        bytes.extend_from_slice(&b);
        clamped += c;
        if level.height == 1 {
            break;
        }
        level = halve(&level);
    }
    Ok((
        ViewTexture {
            name: name.to_string(),
            mapping: mapping.name().to_string(),
            source_width: img.width,
            source_height: img.height,
            levels,
            clamped,
            notice,
        },
        bytes,
    ))
}

/// The next mip level: each texel the mean of a 2×2 block (a lat-long's texels in one block
/// differ in solid angle by under 1 % but at the poles, where the mean is what a GPU's
/// mip chain holds too).
fn halve(img: &Image) -> Image {
    let (w, h, c) = (img.width / 2, img.height / 2, img.channels);
    let mut out = Image::new(w.max(1), h.max(1), c);
    for y in 0..out.height {
        for x in 0..out.width {
            for k in 0..c {
                let mut s = 0.0;
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (sx, sy) = (
                        (2 * x + dx).min(img.width - 1),
                        (2 * y + dy).min(img.height - 1),
                    );
                    s += img.data[(sy * img.width + sx) * c + k];
                }
                out.data[(y * out.width + x) * c + k] = 0.25 * s;
            }
        }
    }
    out
}

/// RGBA half floats of `img` (grey to R, G and B; alpha 1 unless the image has one), and how
/// many values were clamped to the half-float range.
pub fn half_rgba(img: &Image) -> (Vec<u8>, usize) {
    let c = img.channels;
    let mut out = Vec::with_capacity(img.width * img.height * 8);
    let mut clamped = 0;
    for p in img.data.chunks_exact(c) {
        let rgba = match c {
            1 => [p[0], p[0], p[0], 1.0],
            2 => [p[0], p[0], p[0], p[1]],
            3 => [p[0], p[1], p[2], 1.0],
            _ => [p[0], p[1], p[2], p[3]],
        };
        for v in rgba {
            let v = if v.abs() > HALF_MAX {
                clamped += 1;
                HALF_MAX.copysign(v)
            } else {
                v
            };
            out.extend_from_slice(&exr::prelude::f16::from_f32(v).to_le_bytes());
        }
    }
    (out, clamped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn env_width_follows_the_map() {
        assert_eq!(env_width(2048, 1024), 2048);
        assert_eq!(env_width(512, 256), 512);
        assert_eq!(env_width(8192, 4096), ENV_MAX_WIDTH);
        assert_eq!(env_width(4, 2), ENV_MIN_WIDTH);
        // A cube of 256² faces: 6 × 256² texels, a lat-long of about 887 → 1024.
        assert_eq!(env_width(256, 256 * 6), 1024);
    }

    #[test]
    fn the_default_view_is_the_teapot_in_the_bundled_hdri() {
        let d = ViewData::load(None, None, &EnvRequest::default(), None).unwrap();
        assert_eq!(d.scene.mesh.vertices, 792);
        assert_eq!(d.mesh.len(), 792 * 24 + d.scene.mesh.triangles * 12);
        let env = d.scene.env.as_ref().unwrap();
        assert_eq!(env.levels[0], (512, 256, 0));
        assert_eq!(
            *env.levels.last().unwrap(),
            (2, 1, env.levels.last().unwrap().2)
        );
        let total: usize = env.levels.iter().map(|l| l.0 * l.1 * 8).sum();
        assert_eq!(d.env.as_ref().unwrap().len(), total);
        assert!(d.matcap.is_none());
        // The page's GLSL is the core's.
        assert!(d.scene.glsl.texgen.contains("sphere_map_texgen"));
    }

    #[test]
    fn the_payload_is_a_world_lat_long() {
        // A map that is +X red, elsewhere black, given as a cube: the lat-long's centre column
        // (u = ½, +X in the default preset) at the equator is red, u = 0 (−X) is black.
        let cube = Mapping::parse("cube", None).unwrap();
        let f = 32;
        let mut img = Image::new(f, 6 * f, 3);
        for p in img.data.chunks_exact_mut(3).take(f * f) {
            p[0] = 1.0;
        }
        let (info, bytes) =
            env_payload(&img, cube, crate::frame::view::IDENTITY, "cube", None).unwrap();
        let (w, h, _) = info.levels[0];
        let px = |x: usize, y: usize| {
            let o = (y * w + x) * 8;
            exr::prelude::f16::from_le_bytes([bytes[o], bytes[o + 1]]).to_f32()
        };
        assert!(px(w / 2, h / 2) > 0.99, "{}", px(w / 2, h / 2));
        assert!(px(0, h / 2) < 0.01);
    }

    #[test]
    fn half_floats_clamp_and_count() {
        let img = Image {
            width: 2,
            height: 1,
            channels: 1,
            data: vec![1e6, 0.5],
        };
        let (b, clamped) = half_rgba(&img);
        assert_eq!(clamped, 3);
        assert_eq!(b.len(), 16);
        assert_eq!(
            exr::prelude::f16::from_le_bytes([b[0], b[1]]).to_f32(),
            65504.0
        );
        assert_eq!(exr::prelude::f16::from_le_bytes([b[8], b[9]]).to_f32(), 0.5);
    }
}
