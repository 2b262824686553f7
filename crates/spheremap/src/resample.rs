//! The conversion engine: any mapping to any mapping, destination-driven, footprint-filtered.
//!
//! ## What one output texel is
//!
//! For output texel (x, y) the engine spreads samples over the support of the reconstruction
//! filter centred on the texel (the texel itself for the default 1-texel **box**; 2 texels wide
//! for **tent**; 3 texels for **gaussian**, σ = ½ texel), on an n_x × n_y grid of strata with one
//! jittered sample in each (deterministic: the jitter is a hash of the texel, the stratum and the
//! seed).  Each sample's canvas point becomes a direction (the destination mapping's inverse),
//! turns by the view rotation into the source's frame, and is looked up **bilinearly** in the
//! source with the source's wrap rule.  The texel is the weighted mean, the weight of a sample
//! being `filter(dx)·filter(dy)·dω/dA` — the mapping's solid-angle density, so that a box
//! average is an average over solid angle and energy is preserved (a lat-long texel near a pole
//! is not averaged as if it were flat).
//!
//! ## How many samples
//!
//! * `samples = 1`: exactly one lookup at the texel centre; no jitter, no adaptation — what
//!   skylibs, py360convert and a GPU `texture()` call do, for comparisons.
//! * `samples = S > 1`: at least S (n = ⌈√S⌉ per axis), and more where the texel's footprint
//!   in the source spans more source texels: the footprint is measured by mapping the texel's
//!   edge midpoints into source pixels, and each axis gets at least one sample per source texel
//!   it crosses (the stretched rim of a sphere map, the poles of a lat-long, minification), up to
//!   `max_samples` per texel.  So the result does not alias where a texel covers many.
//!
//! ## Source wrap rules (bilinear taps that fall off the canvas or off the map)
//!
//! * lat-long: u wraps; past a pole, v reflects and u turns by ½ (continuous over the pole);
//! * cube: a tap past a face edge is the texel of the neighbouring face that its direction
//!   hits (seams are crossed, corners included);
//! * octahedral: pbrt's fold (reflect across the edge, flip the other axis);
//! * sphere, angular, paraboloid: only taps whose texel centre lies inside the disc count, and
//!   the bilinear weights are renormalized over them — whatever the file holds outside the disc
//!   (black, a gutter, a photo's background) never bleeds in.
//!
//! ## Outside a destination disc
//!
//! Sphere, angular and paraboloid outputs have corners that are off the map.  [`Outside::Gutter`]
//! (the default) fills them with the radial mirror image of the map across the rim (the texel at
//! radius 1 + ε shows what radius 1 − ε shows), so GPU bilinear and mipmap lookups near the rim
//! average real neighbours and show no dark fringe; [`Outside::Black`] writes 0 there, and rim
//! texels get the covered fraction of their footprint (an anti-aliased edge).
//!
//! ## Precision
//!
//! [`Precision::F32`] (default) computes directions in f32 with the fast polynomial atan2;
//! [`Precision::F64`] is the reference path (f64 maths and accumulation, libm trig).  They are
//! tested against each other.

use crate::conventions::mat3_mul;
use crate::cube;
use crate::error::{Error, Result};
use crate::image_io::Image;
use crate::mapping::Mapping;
use crate::real::Real;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

/// Reconstruction filter over the output texel's footprint.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Filter {
    /// The 1-texel box: the plain (solid-angle weighted) average over the texel. Default.
    #[default]
    Box,
    /// Tent, radius 1 texel.
    Tent,
    /// Gaussian, σ = ½ texel, truncated at 1.5 texels.
    Gaussian,
}

impl Filter {
    pub const NAMES: [&'static str; 3] = ["box", "tent", "gaussian"];
    pub fn parse(name: &str) -> Result<Filter> {
        match name {
            "box" => Ok(Filter::Box),
            "tent" | "triangle" => Ok(Filter::Tent),
            "gaussian" | "gauss" => Ok(Filter::Gaussian),
            other => Err(Error::param(
                "filter",
                format!("unknown filter {other:?}; expected one of: box, tent, gaussian"),
            )),
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Filter::Box => "box",
            Filter::Tent => "tent",
            Filter::Gaussian => "gaussian",
        }
    }
    /// Half-width of the support, in output texels.
    pub(crate) fn radius(self) -> f64 {
        match self {
            Filter::Box => 0.5,
            Filter::Tent => 1.0,
            Filter::Gaussian => 1.5,
        }
    }
    #[inline]
    pub(crate) fn weight(self, d: f64) -> f64 {
        match self {
            Filter::Box => 1.0,
            Filter::Tent => (1.0 - d.abs()).max(0.0),
            Filter::Gaussian => (-2.0 * d * d).exp(),
        }
    }
}

/// What to write where a destination disc mapping has no direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Outside {
    /// The radial mirror image across the rim (no dark fringe under GPU filtering). Default.
    #[default]
    Gutter,
    /// Zero; rim texels hold their covered fraction.
    Black,
}

impl Outside {
    pub fn parse(name: &str) -> Result<Outside> {
        match name {
            "gutter" => Ok(Outside::Gutter),
            "black" => Ok(Outside::Black),
            other => Err(Error::param(
                "outside",
                format!("unknown fill {other:?}; expected gutter or black"),
            )),
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Outside::Gutter => "gutter",
            Outside::Black => "black",
        }
    }
}

/// Arithmetic of the direction computations.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Precision {
    #[default]
    F32,
    F64,
}

impl Precision {
    pub fn parse(name: &str) -> Result<Precision> {
        match name {
            "f32" => Ok(Precision::F32),
            "f64" => Ok(Precision::F64),
            other => Err(Error::param(
                "precision",
                format!("unknown value {other:?}; expected f32 or f64"),
            )),
        }
    }
}

/// Options of [`resample`].
#[derive(Clone, Copy, Debug)]
pub struct ResampleOptions {
    /// Samples per output texel: 1 = one centre lookup; S > 1 = at least S, adaptive.
    pub samples: u32,
    /// The most samples one texel may take when adapting.
    pub max_samples: u32,
    pub filter: Filter,
    pub outside: Outside,
    /// Row-major rotation taking directions in the destination's frame to the source's frame
    /// (its columns are the destination's +X, +Y, +Z axes in source coordinates); see
    /// [`crate::view`].
    pub rotation: [[f64; 3]; 3],
    pub seed: u64,
    pub precision: Precision,
    /// Refuse a job whose estimated allocation is over this many bytes
    /// ([`crate::error::default_max_memory`]).
    pub max_memory: u64,
}

/// The default sample count (adaptive, at least 4 per texel).
pub const DEFAULT_SAMPLES: u32 = 4;
/// Upper bound on `samples` and `max_samples`.
pub const SAMPLE_CAP: u32 = 65_536;

impl Default for ResampleOptions {
    fn default() -> Self {
        ResampleOptions {
            samples: DEFAULT_SAMPLES,
            max_samples: 1024,
            filter: Filter::Box,
            outside: Outside::Gutter,
            rotation: IDENTITY,
            seed: 0,
            precision: Precision::F32,
            max_memory: crate::error::default_max_memory(),
        }
    }
}

pub const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// An environment map in memory: a mapping and its canvas.
#[derive(Clone, Copy, Debug)]
pub struct EnvMap<'a> {
    pub mapping: Mapping,
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub data: &'a [f32],
}

impl<'a> EnvMap<'a> {
    /// Checks the canvas shape against the mapping (`what` names the input in errors).
    pub fn new(mapping: Mapping, img: &'a Image, what: &str) -> Result<Self> {
        mapping.size_of(img.width, img.height, what)?;
        if !(1..=4).contains(&img.channels) {
            return Err(Error::data(
                what,
                format!("{} channels; 1 to 4 are supported", img.channels),
            ));
        }
        Ok(EnvMap {
            mapping,
            width: img.width,
            height: img.height,
            channels: img.channels,
            data: &img.data,
        })
    }
}

/// Bilinear lookups of directions in an environment map, with the map's wrap rules — what the
/// conversion engine does for each sample, for callers with their own directions (a scene's
/// environment, the generator's environment-map ray source).
pub struct Sampler<'a> {
    src: Src<'a, f32>,
    channels: usize,
}

impl<'a> Sampler<'a> {
    pub fn new(env: &EnvMap<'a>) -> Self {
        Sampler {
            src: Src::new(env),
            channels: env.channels,
        }
    }

    pub fn channels(&self) -> usize {
        self.channels
    }

    /// The map's value in direction `d` (any length but 0) into `out[..channels]`.
    #[inline]
    pub fn sample(&self, d: [f32; 3], out: &mut [f32]) {
        let p = self.src.position(d);
        match self.channels {
            1 => self.put::<1>(p, out),
            2 => self.put::<2>(p, out),
            3 => self.put::<3>(p, out),
            4 => self.put::<4>(p, out),
            5 => self.put::<5>(p, out),
            6 => self.put::<6>(p, out),
            7 => self.put::<7>(p, out),
            _ => self.put::<8>(p, out),
        }
    }

    #[inline]
    fn put<const C: usize>(&self, p: [f32; 2], out: &mut [f32]) {
        let mut acc = [0f32; C];
        self.src.lookup(p, 1.0, &mut acc);
        out[..C].copy_from_slice(&acc);
    }
}

/// Shared progress and cancellation: workers add finished rows to `done` and stop early when
/// `cancel` is set (the result is then an error).
#[derive(Debug, Default)]
pub struct Progress {
    pub done: AtomicUsize,
    pub total: AtomicUsize,
    pub cancel: AtomicBool,
}

/// What a run did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ResampleReport {
    /// Source lookups in all.
    pub lookups: u64,
    /// The most samples any texel took.
    pub max_texel_samples: u32,
}

/// Resamples `src` into a `width`×`height` canvas of `dst` (for a cube: the F×6F face stack).
pub fn resample(
    src: &EnvMap,
    dst: Mapping,
    width: usize,
    height: usize,
    opts: &ResampleOptions,
    progress: Option<&Progress>,
) -> Result<(Image, ResampleReport)> {
    dst.size_of(width, height, "size")
        .map_err(|e| Error::param("size", e.to_string()))?;
    if opts.samples == 0 || opts.samples > SAMPLE_CAP {
        return Err(Error::param(
            "samples",
            format!("{} is out of range 1..={SAMPLE_CAP}", opts.samples),
        ));
    }
    if opts.max_samples == 0 || opts.max_samples > SAMPLE_CAP {
        return Err(Error::param(
            "max_samples",
            format!("{} is out of range 1..={SAMPLE_CAP}", opts.max_samples),
        ));
    }
    check_rotation(&opts.rotation)?;
    // The output, and as much again for whoever encodes it.
    crate::error::check_memory(
        "size",
        2 * (width as u128 * height as u128 * src.channels as u128 * 4),
        opts.max_memory,
    )?;
    let (w, h) = (width, height);
    let (out, report) = match (opts.precision, src.channels) {
        (Precision::F32, 1) => run::<f32, 1>(src, dst, w, h, opts, progress),
        (Precision::F32, 2) => run::<f32, 2>(src, dst, w, h, opts, progress),
        (Precision::F32, 3) => run::<f32, 3>(src, dst, w, h, opts, progress),
        (Precision::F32, _) => run::<f32, 4>(src, dst, w, h, opts, progress),
        (Precision::F64, 1) => run::<f64, 1>(src, dst, w, h, opts, progress),
        (Precision::F64, 2) => run::<f64, 2>(src, dst, w, h, opts, progress),
        (Precision::F64, 3) => run::<f64, 3>(src, dst, w, h, opts, progress),
        (Precision::F64, _) => run::<f64, 4>(src, dst, w, h, opts, progress),
    };
    if progress.is_some_and(|p| p.cancel.load(Ordering::Relaxed)) {
        return Err(Error::cancelled("the conversion"));
    }
    Ok((out, report))
}

pub(crate) fn check_rotation(r: &[[f64; 3]; 3]) -> Result<()> {
    for i in 0..3 {
        for j in 0..3 {
            let d: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
            let want = if i == j { 1.0 } else { 0.0 };
            if !((d - want).abs() < 1e-6) {
                return Err(Error::param(
                    "rotation",
                    "not a rotation (its columns must be orthonormal)",
                ));
            }
        }
    }
    Ok(())
}

/// The source side: canvas, wrap rules, bilinear lookups.
struct Src<'a, T: Real> {
    m: Mapping,
    w: usize,
    h: usize,
    data: &'a [f32],
    wf: T,
    hf: T,
    /// Cube face size (the canvas width) — 0 for other mappings.
    face: usize,
    /// Disc mappings: a sample this close to the centre (in pixels, squared) has all four taps
    /// inside the disc.
    safe_r2: T,
}

impl<'a, T: Real> Src<'a, T> {
    fn new(e: &EnvMap<'a>) -> Self {
        let n = e.height as f64; // disc diameter (sphere/angular: N; paraboloid: N per half)
        let safe = (0.5 * n - 1.5).max(0.0);
        Src {
            m: e.mapping,
            w: e.width,
            h: e.height,
            data: e.data,
            wf: T::from_f64(e.width as f64),
            hf: T::from_f64(e.height as f64),
            face: if matches!(e.mapping, Mapping::Cube(_)) {
                e.width
            } else {
                0
            },
            safe_r2: T::from_f64(safe * safe),
        }
    }

    /// Continuous source pixel position of a direction (NaN-free: the sphere map's single
    /// singular direction is placed on its rim).
    #[inline(always)]
    fn position(&self, d: [T; 3]) -> [T; 2] {
        if let Mapping::Cube(p) = self.m {
            // Straight from the face table (not via the canvas v, whose ×6 could round onto the
            // neighbouring face); t kept below 1 so the face stays recoverable from the row.
            let (face, s, t) = cube::dir_to_face_st(mat3_mul(&p.frame, d));
            let t = t.min(T::from_f64(1.0 - 1.0 / 4096.0));
            return [s * self.wf, (T::from_f64(face as f64) + t) * self.wf];
        }
        let [u, v] = self.m.dir_to_uv(d);
        if u.is_nan() {
            // Only the sphere map's straight-ahead direction (a point of measure zero): the rim.
            return [self.wf, self.hf * T::HALF];
        }
        [u * self.wf, v * self.hf]
    }

    /// Bilinear lookup at continuous pixel position `p`, accumulating `weight ×` the value.
    #[inline(always)]
    fn lookup<const C: usize>(&self, p: [T; 2], weight: T, acc: &mut [T; C]) {
        let px = p[0] - T::HALF;
        let py = p[1] - T::HALF;
        let fx0 = px.floor();
        let fy0 = py.floor();
        let (ax, ay) = (px - fx0, py - fy0);
        let x0 = fx0.to_f64() as isize;
        let y0 = fy0.to_f64() as isize;
        let wts = [
            (T::ONE - ax) * (T::ONE - ay),
            ax * (T::ONE - ay),
            (T::ONE - ax) * ay,
            ax * ay,
        ];
        if self.fast(x0, y0, p) {
            let i00 = (y0 as usize * self.w + x0 as usize) * C;
            let i10 = i00 + C;
            let i01 = i00 + self.w * C;
            let i11 = i01 + C;
            for k in 0..C {
                let v = wts[0] * T::from_f64(self.data[i00 + k] as f64)
                    + wts[1] * T::from_f64(self.data[i10 + k] as f64)
                    + wts[2] * T::from_f64(self.data[i01 + k] as f64)
                    + wts[3] * T::from_f64(self.data[i11 + k] as f64);
                acc[k] = acc[k] + weight * v;
            }
            return;
        }
        // Slow path: each tap through the wrap rule; missing taps renormalize the rest.
        let taps = [(x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)];
        let mut idx = [usize::MAX; 4];
        let mut wsum = T::ZERO;
        for (j, &(x, y)) in taps.iter().enumerate() {
            if let Some(i) = self.tap(x, y, p) {
                idx[j] = i;
                wsum = wsum + wts[j];
            }
        }
        if !(wsum > T::ZERO) {
            // All taps off the map (a sample in the last half texel of a tiny disc): nearest.
            let i = self.nearest(p);
            for k in 0..C {
                acc[k] = acc[k] + weight * T::from_f64(self.data[i * C + k] as f64);
            }
            return;
        }
        let norm = weight / wsum;
        for j in 0..4 {
            if idx[j] == usize::MAX {
                continue;
            }
            let wj = wts[j] * norm;
            for k in 0..C {
                acc[k] = acc[k] + wj * T::from_f64(self.data[idx[j] * C + k] as f64);
            }
        }
    }

    /// All four taps of (x0, y0) are plain texels of the same tile (no wrap, inside the disc).
    #[inline(always)]
    fn fast(&self, x0: isize, y0: isize, p: [T; 2]) -> bool {
        if x0 < 0 || y0 < 0 || x0 as usize + 1 >= self.w || y0 as usize + 1 >= self.h {
            return false;
        }
        match self.m {
            Mapping::LatLong(_) | Mapping::Octahedral => true,
            Mapping::Cube(_) => {
                let f = self.face;
                (y0 as usize) / f == (y0 as usize + 1) / f
            }
            Mapping::Sphere(_) | Mapping::Angular => {
                let c = self.hf * T::HALF;
                let (dx, dy) = (p[0] - c, p[1] - c);
                dx * dx + dy * dy <= self.safe_r2
            }
            Mapping::Paraboloid => {
                let n = self.h as isize;
                if (x0 < n) != (x0 + 1 < n) {
                    return false;
                }
                let c = self.hf * T::HALF;
                let cx = if x0 < n { c } else { c + self.hf };
                let (dx, dy) = (p[0] - cx, p[1] - c);
                dx * dx + dy * dy <= self.safe_r2
            }
        }
    }

    /// Index of tap (x, y) under the wrap rule, or `None` when it is off the map.  `p` is the
    /// sample position (it says which cube face / paraboloid half the lookup belongs to).
    fn tap(&self, x: isize, y: isize, p: [T; 2]) -> Option<usize> {
        let (w, h) = (self.w as isize, self.h as isize);
        let inside_disc = |x: isize, y: isize, cx: f64, n: f64| {
            let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - 0.5 * n);
            dx * dx + dy * dy <= 0.25 * n * n
        };
        match self.m {
            Mapping::LatLong(_) => {
                let (mut x, mut y) = (x, y);
                if y < 0 {
                    y = -y - 1;
                    x += w / 2;
                } else if y >= h {
                    y = 2 * h - 1 - y;
                    x += w / 2;
                }
                let x = x.rem_euclid(w);
                Some((y.clamp(0, h - 1) * w + x) as usize)
            }
            Mapping::Octahedral => {
                let (mut x, mut y) = (x, y);
                for _ in 0..2 {
                    if x < 0 {
                        x = -x - 1;
                        y = h - 1 - y;
                    } else if x >= w {
                        x = 2 * w - 1 - x;
                        y = h - 1 - y;
                    }
                    if y < 0 {
                        y = -y - 1;
                        x = w - 1 - x;
                    } else if y >= h {
                        y = 2 * h - 1 - y;
                        x = w - 1 - x;
                    }
                }
                Some((y.clamp(0, h - 1) * w + x.clamp(0, w - 1)) as usize)
            }
            Mapping::Sphere(_) | Mapping::Angular => {
                let inb = x >= 0 && y >= 0 && x < w && y < h;
                (inb && inside_disc(x, y, 0.5 * w as f64, w as f64)).then(|| (y * w + x) as usize)
            }
            Mapping::Paraboloid => {
                let n = h;
                let back = p[0].to_f64() >= n as f64;
                let (lo, hi) = if back { (n, 2 * n) } else { (0, n) };
                let inb = x >= lo && x < hi && y >= 0 && y < h;
                let cx = (lo as f64) + 0.5 * n as f64;
                (inb && inside_disc(x, y, cx, n as f64)).then(|| (y * w + x) as usize)
            }
            Mapping::Cube(_) => {
                let f = self.face as isize;
                let face = ((p[1].to_f64() / f as f64).floor() as isize).clamp(0, 5);
                let ly = y - face * f;
                if x >= 0 && x < f && ly >= 0 && ly < f {
                    return Some((y * w + x) as usize);
                }
                // Across a seam: the tap's centre on the extended face plane, re-projected onto
                // the face its direction hits.
                let (s, t) = ((x as f64 + 0.5) / f as f64, (ly as f64 + 0.5) / f as f64);
                let q = cube::face_st_to_point(face as usize, s, t);
                let (f2, s2, t2) = cube::dir_to_face_st(q);
                let cx = ((s2 * f as f64) as isize).clamp(0, f - 1);
                let cy = ((t2 * f as f64) as isize).clamp(0, f - 1);
                Some(((f2 as isize * f + cy) * w + cx) as usize)
            }
        }
    }

    /// The texel nearest to `p` that is on the map.
    fn nearest(&self, p: [T; 2]) -> usize {
        let (mut x, mut y) = (p[0].to_f64(), p[1].to_f64());
        if matches!(
            self.m,
            Mapping::Sphere(_) | Mapping::Angular | Mapping::Paraboloid
        ) {
            // Pull the point towards its disc's centre until its texel centre is inside.
            let n = self.h as f64;
            let cx = if x >= n && matches!(self.m, Mapping::Paraboloid) {
                1.5 * n
            } else {
                0.5 * n
            };
            let (dx, dy) = (x - cx, y - 0.5 * n);
            let r = dx.hypot(dy).max(1e-12);
            let k = ((0.5 * n - 0.75).max(0.0) / r).min(1.0);
            x = cx + dx * k;
            y = 0.5 * n + dy * k;
        }
        let xi = (x.floor() as isize).clamp(0, self.w as isize - 1) as usize;
        let yi = (y.floor() as isize).clamp(0, self.h as isize - 1) as usize;
        yi * self.w + xi
    }
}

/// The destination side: canvas point → direction (in the source's frame), with the gutter.
pub(crate) struct Dst<T: Real> {
    pub(crate) m: Mapping,
    wf: T,
    hf: T,
    rot: [[T; 3]; 3],
    pub(crate) outside: Outside,
    /// The density varies across the canvas (so samples must be weighted by it).
    pub(crate) weighted: bool,
}

impl<T: Real> Dst<T> {
    /// A `w`×`h` canvas of `m`; `rotation` takes its directions to the source's frame.
    pub(crate) fn new(
        m: Mapping,
        w: usize,
        h: usize,
        rotation: &[[f64; 3]; 3],
        outside: Outside,
    ) -> Self {
        Dst {
            m,
            wf: T::from_f64(w as f64),
            hf: T::from_f64(h as f64),
            rot: rotation.map(|r| r.map(T::from_f64)),
            outside,
            weighted: !matches!(m, Mapping::Sphere(_) | Mapping::Octahedral),
        }
    }

    /// The sample weight's density factor at a canvas point (1 for equal-area mappings).
    #[inline]
    pub(crate) fn density(&self, px: T, py: T) -> f64 {
        if self.weighted {
            self.m.density([px / self.wf, py / self.hf]).to_f64()
        } else {
            1.0
        }
    }

    /// Canvas pixel position → (direction in source frame, counts as on the map).  Off-map
    /// points are mirrored across the rim (gutter) and flagged.
    #[inline(always)]
    pub(crate) fn dir(&self, px: T, py: T) -> ([T; 3], bool) {
        let uv = [px / self.wf, py / self.hf];
        let (d, on) = match self.m.uv_to_dir(uv) {
            Some(d) => (d, true),
            None => (self.mirrored(uv), false),
        };
        let r = &self.rot;
        let rd = [
            r[0][0] * d[0] + r[0][1] * d[1] + r[0][2] * d[2],
            r[1][0] * d[0] + r[1][1] * d[1] + r[1][2] * d[2],
            r[2][0] * d[0] + r[2][1] * d[1] + r[2][2] * d[2],
        ];
        (rd, on)
    }

    /// The direction of the radial mirror image (across the rim) of an off-map canvas point.
    #[cold]
    fn mirrored(&self, uv: [T; 2]) -> [T; 3] {
        let one = T::ONE;
        let (half, back) = match self.m {
            Mapping::Paraboloid => {
                let back = uv[0] >= T::HALF;
                let uh = if back { uv[0] - T::HALF } else { uv[0] } * T::TWO;
                (uh, back)
            }
            _ => (uv[0].max(T::ZERO).min(one), false),
        };
        let (a, b) = (
            T::TWO * half - one,
            T::TWO * uv[1].max(T::ZERO).min(one) - one,
        );
        let rho = a.hypot(b);
        if !(rho > T::ZERO) {
            return self
                .m
                .uv_to_dir([T::HALF, T::HALF])
                .unwrap_or([T::ZERO, T::ZERO, -one]);
        }
        // ρ' = 2 − ρ, kept a hair inside the disc.
        let k = (T::TWO - rho).max(T::ZERO).min(one - T::from_f64(1e-6)) / rho;
        let (a2, b2) = (a * k, b * k);
        let h2 = (a2 + one) * T::HALF;
        let u2 = match self.m {
            Mapping::Paraboloid if back => h2 * T::HALF + T::HALF,
            Mapping::Paraboloid => h2 * T::HALF,
            _ => h2,
        };
        self.m
            .uv_to_dir([u2, (b2 + one) * T::HALF])
            .unwrap_or([T::ZERO, T::ZERO, -one])
    }
}

fn run<T: Real, const C: usize>(
    src: &EnvMap,
    dst: Mapping,
    w: usize,
    h: usize,
    opts: &ResampleOptions,
    progress: Option<&Progress>,
) -> (Image, ResampleReport) {
    let s = Src::<T>::new(src);
    let d = Dst::<T>::new(dst, w, h, &opts.rotation, opts.outside);
    if let Some(p) = progress {
        p.total.store(h, Ordering::Relaxed);
    }
    let lookups = AtomicU64::new(0);
    let max_n = AtomicUsize::new(0);
    // The vectorized one-sample path (f32 only).
    if opts.samples == 1 && std::any::TypeId::of::<T>() == std::any::TypeId::of::<f32>() {
        // SAFETY: T is f32 (the TypeId check above), so Src<T>/Dst<T> are Src<f32>/Dst<f32>.
        let s32: &Src<f32> = unsafe { &*(&s as *const Src<T> as *const Src<f32>) };
        let d32: &Dst<f32> = unsafe { &*(&d as *const Dst<T> as *const Dst<f32>) };
        let plan = rows::Plan::new(s32, d32, &opts.rotation, w);
        // The output is not zeroed first (that pass alone cost 5–13 % of a job): every row
        // writes every one of its values, a cancelled row included.
        let n = w * h * C;
        let mut data: Vec<f32> = Vec::with_capacity(n);
        data.spare_capacity_mut()[..n]
            .par_chunks_mut(w * C)
            .enumerate()
            .with_min_len(4)
            .for_each_init(
                || rows::Scratch::new(w),
                |sc, (y, row)| {
                    if progress.is_some_and(|p| p.cancel.load(Ordering::Relaxed)) {
                        row.iter_mut().for_each(|v| {
                            v.write(0.0);
                        });
                        return;
                    }
                    rows::row::<C>(s32, d32, &plan, y, sc, row);
                    if let Some(p) = progress {
                        p.done.fetch_add(1, Ordering::Relaxed);
                    }
                },
            );
        // SAFETY: the loop above initialized all n values.
        unsafe { data.set_len(n) };
        let out = Image {
            width: w,
            height: h,
            channels: C,
            data,
        };
        let report = ResampleReport {
            lookups: (w * h) as u64,
            max_texel_samples: 1,
        };
        return (out, report);
    }
    let mut out = Image::new(w, h, C);
    out.data
        .par_chunks_mut(w * C)
        .enumerate()
        .with_min_len(4)
        .for_each(|(y, row)| {
            if progress.is_some_and(|p| p.cancel.load(Ordering::Relaxed)) {
                return;
            }
            let (l, m) = if opts.samples == 1 {
                row_single::<T, C>(&s, &d, y, row)
            } else {
                row_filtered::<T, C>(&s, &d, y, row, opts)
            };
            lookups.fetch_add(l, Ordering::Relaxed);
            max_n.fetch_max(m, Ordering::Relaxed);
            if let Some(p) = progress {
                p.done.fetch_add(1, Ordering::Relaxed);
            }
        });
    let report = ResampleReport {
        lookups: lookups.into_inner(),
        max_texel_samples: max_n.into_inner() as u32,
    };
    (out, report)
}

/// One lookup at each texel centre.
fn row_single<T: Real, const C: usize>(
    s: &Src<T>,
    d: &Dst<T>,
    y: usize,
    row: &mut [f32],
) -> (u64, usize) {
    let py = T::from_f64(y as f64 + 0.5);
    for (x, px) in row.chunks_exact_mut(C).enumerate() {
        let (dir, on) = d.dir(T::from_f64(x as f64 + 0.5), py);
        if !on && d.outside == Outside::Black {
            px.fill(0.0);
            continue;
        }
        let mut acc = [T::ZERO; C];
        s.lookup(s.position(dir), T::ONE, &mut acc);
        for k in 0..C {
            px[k] = acc[k].to_f64() as f32;
        }
    }
    (row.len() as u64 / C as u64, 1)
}

/// Footprint-adaptive stratified samples under the filter.
fn row_filtered<T: Real, const C: usize>(
    s: &Src<T>,
    d: &Dst<T>,
    y: usize,
    row: &mut [f32],
    opts: &ResampleOptions,
) -> (u64, usize) {
    let radius = opts.filter.radius();
    let base = (opts.samples as f64).sqrt().ceil() as usize;
    let cap = opts.max_samples as usize;
    let mut lookups = 0u64;
    let mut max_n = 0usize;
    let cy = y as f64 + 0.5;
    for (x, px) in row.chunks_exact_mut(C).enumerate() {
        let cx = x as f64 + 0.5;
        // Footprint: the texel's edge midpoints in source pixels.
        let pos = |ox: f64, oy: f64| {
            let (dir, _) = d.dir(T::from_f64(cx + ox), T::from_f64(cy + oy));
            (dir, s.position(dir))
        };
        let (lx, ly) = {
            let (dl, pl) = pos(-0.5, 0.0);
            let (dr, pr) = pos(0.5, 0.0);
            let (dt, pt) = pos(0.0, -0.5);
            let (db, pb) = pos(0.0, 0.5);
            (s.span(pl, pr, dl, dr), s.span(pt, pb, dt, db))
        };
        let support = 2.0 * radius;
        let (nx, ny) = strata(
            base.max((lx * support).ceil() as usize),
            base.max((ly * support).ceil() as usize),
            opts.samples as usize,
            cap,
        );
        let mut acc = [T::ZERO; C];
        let mut wsum = T::ZERO;
        for j in 0..ny {
            for i in 0..nx {
                let (jx, jy) = jitter(opts.seed, x as u64, y as u64, (j * nx + i) as u64);
                let ox = -radius + (i as f64 + jx) / nx as f64 * support;
                let oy = -radius + (j as f64 + jy) / ny as f64 * support;
                let (sx, sy) = (T::from_f64(cx + ox), T::from_f64(cy + oy));
                let wgt = opts.filter.weight(ox) * opts.filter.weight(oy) * d.density(sx, sy);
                let (dir, on) = d.dir(sx, sy);
                let wt = T::from_f64(wgt);
                wsum = wsum + wt;
                if !on && d.outside == Outside::Black {
                    continue;
                }
                s.lookup(s.position(dir), wt, &mut acc);
                lookups += 1;
            }
        }
        max_n = max_n.max(nx * ny);
        for k in 0..C {
            px[k] = if wsum > T::ZERO {
                (acc[k] / wsum).to_f64() as f32
            } else {
                0.0
            };
        }
    }
    (lookups, max_n)
}

impl<T: Real> Src<'_, T> {
    /// How many source texels lie between two source positions (the directions `da`, `db` are
    /// used where pixel distance means nothing: across a cube seam).
    fn span(&self, a: [T; 2], b: [T; 2], da: [T; 3], db: [T; 3]) -> f64 {
        let (mut dx, dy) = ((b[0] - a[0]).to_f64().abs(), (b[1] - a[1]).to_f64().abs());
        match self.m {
            Mapping::LatLong(_) => dx = dx.min(self.w as f64 - dx),
            Mapping::Cube(_) => {
                let f = self.face as f64;
                if (a[1].to_f64() / f).floor() != (b[1].to_f64() / f).floor() {
                    // Angle between the directions × the densest texels per radian (a face's
                    // corner: 1.5 F).
                    let dot = (0..3).map(|k| (da[k] * db[k]).to_f64()).sum::<f64>();
                    let la = (0..3).map(|k| da[k].to_f64().powi(2)).sum::<f64>().sqrt();
                    let lb = (0..3).map(|k| db[k].to_f64().powi(2)).sum::<f64>().sqrt();
                    let ang = (dot / (la * lb)).clamp(-1.0, 1.0).acos();
                    return ang * 1.5 * f;
                }
            }
            _ => {}
        }
        dx.hypot(dy)
    }
}

/// The strata grid of one texel: at least `samples` in all, then kept within `cap` (the
/// aspect kept).  Shared with the ray-traced generator, so `samples` means the same there.
pub(crate) fn strata(mut nx: usize, mut ny: usize, samples: usize, cap: usize) -> (usize, usize) {
    while nx * ny < samples {
        nx += 1;
    }
    if nx * ny > cap {
        // Keep the aspect and use as much of the cap as the grid allows.
        let k = (cap as f64 / (nx * ny) as f64).sqrt();
        nx = ((nx as f64 * k).round() as usize).clamp(1, cap);
        ny = (cap / nx).max(1);
    }
    (nx, ny)
}

/// Deterministic jitter in [0,1)² for (texel, sample): a 64-bit mix (SplitMix64 finalizer).
#[inline]
pub(crate) fn jitter(seed: u64, x: u64, y: u64, k: u64) -> (f64, f64) {
    let mut z = seed
        ^ x.wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ y.wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ k.wrapping_mul(0x1656_67B1_9E37_79F9);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    let a = (z >> 40) as f64 / (1u64 << 24) as f64;
    let b = ((z >> 16) & 0xFF_FFFF) as f64 / (1u64 << 24) as f64;
    (a, b)
}

/// The one-sample path for f32, in three passes over each output row so the compiler can
/// vectorize the first two: (1) destination directions (branch-free formulas for the sphere
/// map, with its gutter, and tables for the lat-long), (2) source positions (branch-free
/// lat-long, cube and sphere), (3) the bilinear gathers.  Other mappings use the generic
/// per-texel functions in passes 1–2.  Same formulas as the generic path (tested equal).
mod rows {
    use super::*;
    use crate::real::{atan2_fast, floor_fast};
    use crate::RowOrder;

    pub(super) struct Scratch {
        d: [Vec<f32>; 3],
        on: Vec<bool>,
        p: [Vec<f32>; 2],
        /// Pass 2b: the top-left tap's index into the source data, or `SLOW` when the lookup
        /// needs the general path; and the bilinear fractions.
        idx: Vec<u32>,
        frac: [Vec<f32>; 2],
    }

    /// `Scratch::idx` of a lookup that takes the general path.
    const SLOW: u32 = u32::MAX;

    impl Scratch {
        pub(super) fn new(w: usize) -> Self {
            Scratch {
                d: [vec![0.0; w], vec![0.0; w], vec![0.0; w]],
                on: vec![false; w],
                p: [vec![0.0; w], vec![0.0; w]],
                idx: vec![SLOW; w],
                frac: [vec![0.0; w], vec![0.0; w]],
            }
        }
    }

    /// Per-run constants.
    pub(super) struct Plan {
        /// Sphere destination: rotation · (preset frame)ᵀ, eye → source frame.
        sphere_m: [[f32; 3]; 3],
        /// Lat-long destination: cos φ, sin φ per column.
        cos_phi: Vec<f32>,
        sin_phi: Vec<f32>,
        /// Source preset frame (sphere, cube): source frame → the mapping's eye/GL frame.
        src_frame: [[f32; 3]; 3],
    }

    impl Plan {
        pub(super) fn new(s: &Src<f32>, d: &Dst<f32>, rot: &[[f64; 3]; 3], w: usize) -> Self {
            use crate::view::{mul, transpose};
            let sphere_m = match d.m {
                Mapping::Sphere(p) => mul(rot, &transpose(&p.frame)),
                _ => *rot,
            }
            .map(|r| r.map(|v| v as f32));
            let (mut cos_phi, mut sin_phi) = (vec![], vec![]);
            if let Mapping::LatLong(p) = d.m {
                for x in 0..w {
                    let phi = ((x as f64 + 0.5) / w as f64 - p.u_plus_x) * std::f64::consts::TAU;
                    cos_phi.push(phi.cos() as f32);
                    sin_phi.push(phi.sin() as f32);
                }
            }
            let src_frame = match s.m {
                Mapping::Sphere(p) => p.frame,
                Mapping::Cube(p) => p.frame,
                _ => IDENTITY,
            }
            .map(|r| r.map(|v| v as f32));
            Plan {
                sphere_m,
                cos_phi,
                sin_phi,
                src_frame,
            }
        }
    }

    #[inline(always)]
    fn apply(m: &[[f32; 3]; 3], e: [f32; 3]) -> [f32; 3] {
        // Written out: `[0, 1, 2].map(..)` is not inlined and stops vectorization.
        [
            m[0][0] * e[0] + m[0][1] * e[1] + m[0][2] * e[2],
            m[1][0] * e[0] + m[1][1] * e[1] + m[1][2] * e[2],
            m[2][0] * e[0] + m[2][1] * e[1] + m[2][2] * e[2],
        ]
    }

    /// Passes 1 and 2 for row `y`.
    #[inline(always)]
    fn stages<const C: usize>(s: &Src<f32>, d: &Dst<f32>, plan: &Plan, y: usize, sc: &mut Scratch) {
        let w = sc.on.len();
        let [dx, dy, dz] = &mut sc.d;
        let on = &mut sc.on;
        match d.m {
            Mapping::Sphere(p) => {
                let yf = (2.0 * (y as f64 + 0.5) / d.hf as f64 - 1.0) as f32;
                let b = match p.rows {
                    RowOrder::TopIsT1 => -yf,
                    RowOrder::TopIsT0 => yf,
                };
                let (k0, k1) = (2.0 / w as f32, 1.0 / w as f32 - 1.0);
                let m = &plan.sphere_m;
                for x in 0..w {
                    let a = x as f32 * k0 + k1;
                    let d2 = a * a + b * b;
                    let inside = d2 <= 1.0;
                    // Gutter: the radial mirror image across the rim (see `Dst::mirrored`).
                    let rho = d2.sqrt();
                    let k = if inside {
                        1.0
                    } else {
                        (2.0 - rho).clamp(0.0, 1.0 - 1e-6) / rho
                    };
                    let (a2, b2) = (a * k, b * k);
                    let q = a2 * a2 + b2 * b2;
                    let z2 = 2.0 * (1.0 - q).max(0.0).sqrt();
                    let r = apply(m, [z2 * a2, z2 * b2, 1.0 - 2.0 * q]);
                    dx[x] = r[0];
                    dy[x] = r[1];
                    dz[x] = r[2];
                    on[x] = inside;
                }
            }
            Mapping::LatLong(_) => {
                let theta = (y as f64 + 0.5) / d.hf as f64 * std::f64::consts::PI;
                let (st, ct) = (theta.sin() as f32, theta.cos() as f32);
                let m = &plan.sphere_m;
                for x in 0..w {
                    let r = apply(m, [st * plan.cos_phi[x], ct, st * plan.sin_phi[x]]);
                    dx[x] = r[0];
                    dy[x] = r[1];
                    dz[x] = r[2];
                    on[x] = true;
                }
            }
            _ => {
                let py = y as f32 + 0.5;
                for x in 0..w {
                    let (r, o) = d.dir(x as f32 + 0.5, py);
                    dx[x] = r[0];
                    dy[x] = r[1];
                    dz[x] = r[2];
                    on[x] = o;
                }
            }
        }
        let [px, py] = &mut sc.p;
        let (wf, hf) = (s.wf, s.hf);
        match s.m {
            Mapping::LatLong(p) => {
                let u0 = p.u_plus_x as f32;
                let (i2pi, ipi) = (1.0 / std::f32::consts::TAU, 1.0 / std::f32::consts::PI);
                for x in 0..w {
                    let (a, b, c) = (dx[x], dy[x], dz[x]);
                    let u = u0 + atan2_fast(c, a) * i2pi;
                    let u = u - floor_fast(u);
                    let v = atan2_fast((a * a + c * c).sqrt(), b) * ipi;
                    px[x] = u * wf;
                    py[x] = v * hf;
                }
            }
            Mapping::Cube(_) => {
                let m = &plan.src_frame;
                let f = wf;
                for x in 0..w {
                    let [a, b, c] = apply(m, [dx[x], dy[x], dz[x]]);
                    let (ax, ay, az) = (a.abs(), b.abs(), c.abs());
                    let is_x = ax >= ay && ax >= az;
                    let is_y = !is_x && ay >= az;
                    // The GL face table (crate::cube), branch-free.
                    let ma = if is_x {
                        a
                    } else if is_y {
                        b
                    } else {
                        c
                    };
                    let sgn = if ma < 0.0 { -1.0 } else { 1.0 };
                    let scv = if is_x {
                        -c * sgn
                    } else if is_y {
                        a
                    } else {
                        a * sgn
                    };
                    let tcv = if is_x {
                        -b
                    } else if is_y {
                        c * sgn
                    } else {
                        -b
                    };
                    let axis = if is_x {
                        0.0
                    } else if is_y {
                        2.0
                    } else {
                        4.0
                    };
                    let face = axis + if ma < 0.0 { 1.0 } else { 0.0 };
                    let inv = 1.0 / ma.abs();
                    let ss = (scv * inv + 1.0) * 0.5;
                    let tt = ((tcv * inv + 1.0) * 0.5).min(1.0 - 1.0 / 4096.0);
                    px[x] = ss * f;
                    py[x] = (face + tt) * f;
                }
            }
            Mapping::Sphere(p) => {
                let m = &plan.src_frame;
                let flip = matches!(p.rows, RowOrder::TopIsT1);
                for x in 0..w {
                    let [a, b, c] = apply(m, [dx[x], dy[x], dz[x]]);
                    let il = 1.0 / (a * a + b * b + c * c).sqrt();
                    let (a, b, c) = (a * il, b * il, c * il);
                    let q = a * a + b * b;
                    // 1 + z without cancellation (crate::sphere::dir_to_st).
                    let zp1 = if c >= 0.0 { 1.0 + c } else { q / (1.0 - c) };
                    let h2 = q + zp1 * zp1;
                    let k = 0.5 / h2.sqrt();
                    let (ss, tt) = if h2 > 0.0 {
                        (a * k + 0.5, b * k + 0.5)
                    } else {
                        (1.0, 0.5) // straight ahead: the rim
                    };
                    let v = if flip { 1.0 - tt } else { tt };
                    px[x] = ss * wf;
                    py[x] = v * hf;
                }
            }
            _ => {
                for x in 0..w {
                    let q = s.position([dx[x], dy[x], dz[x]]);
                    px[x] = q[0];
                    py[x] = q[1];
                }
            }
        }
    }

    /// Pass 2b: for each position, the index of its top-left tap and the bilinear fractions
    /// when all four taps are plain texels of one tile (no wrap, not near a disc's rim, not
    /// across a cube seam) — the common case of `Src::lookup` — else `SLOW`.
    #[inline(always)]
    fn taps<const C: usize>(s: &Src<f32>, sc: &mut Scratch) {
        // Indices are u32: a source too large for them takes the general path throughout.
        if s.data.len() >= SLOW as usize {
            sc.idx.fill(SLOW);
            return;
        }
        let c = s.hf * 0.5;
        let face = s.wf;
        let r2 = s.safe_r2;
        match s.m {
            Mapping::LatLong(_) | Mapping::Octahedral => taps_with::<C>(s, sc, |_, _, _| true),
            // Both tap rows on the face the position belongs to.
            Mapping::Cube(_) => taps_with::<C>(s, sc, |_, p1, fy| {
                let f0 = (p1 / face).floor() * face;
                fy >= f0 && fy + 1.0 < f0 + face
            }),
            Mapping::Sphere(_) | Mapping::Angular => taps_with::<C>(s, sc, |p0, p1, _| {
                let (dx, dy) = (p0 - c, p1 - c);
                dx * dx + dy * dy <= r2
            }),
            Mapping::Paraboloid => sc.idx.fill(SLOW),
        }
    }

    /// Pass 2b's loop; `tile_ok(px, py, floor(py − ½))` is the mapping's own condition.
    /// (`floor` here is one instruction: the callers are compiled for AVX2.)
    #[inline(always)]
    fn taps_with<const C: usize>(
        s: &Src<f32>,
        sc: &mut Scratch,
        tile_ok: impl Fn(f32, f32, f32) -> bool,
    ) {
        let [px, py] = &sc.p;
        let [ax, ay] = &mut sc.frac;
        let idx = &mut sc.idx;
        let (wf, hf) = (s.wf, s.hf);
        let row = (s.w * C) as u32;
        for x in 0..idx.len() {
            let (p0, p1) = (px[x], py[x]);
            let (qx, qy) = (p0 - 0.5, p1 - 0.5);
            let (fx, fy) = (qx.floor(), qy.floor());
            // Written as `!(in range)` so that NaN positions fail too.
            let ok =
                tile_ok(p0, p1, fy) && fx >= 0.0 && fy >= 0.0 && fx + 1.0 < wf && fy + 1.0 < hf;
            // SAFETY: clamped into 0..=w and 0..=h first (NaN becomes 0), so the conversions
            // are in range; plain `as` would add a saturating fix-up that stops vectorization.
            let (xi, yi) = unsafe {
                (
                    fx.max(0.0).min(wf).to_int_unchecked::<i32>() as u32,
                    fy.max(0.0).min(hf).to_int_unchecked::<i32>() as u32,
                )
            };
            idx[x] = if ok { yi * row + xi * C as u32 } else { SLOW };
            ax[x] = qx - fx;
            ay[x] = qy - fy;
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn stages_avx2<const C: usize>(
        s: &Src<f32>,
        d: &Dst<f32>,
        plan: &Plan,
        y: usize,
        sc: &mut Scratch,
    ) {
        stages::<C>(s, d, plan, y, sc)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn taps_avx2<const C: usize>(s: &Src<f32>, sc: &mut Scratch) {
        taps::<C>(s, sc)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx2,fma")]
    unsafe fn stages_avx512<const C: usize>(
        s: &Src<f32>,
        d: &Dst<f32>,
        plan: &Plan,
        y: usize,
        sc: &mut Scratch,
    ) {
        stages::<C>(s, d, plan, y, sc);
        taps::<C>(s, sc)
    }

    /// Passes 1–2 with the widest vectors this CPU has, then pass 3.
    pub(super) fn row<const C: usize>(
        s: &Src<f32>,
        d: &Dst<f32>,
        plan: &Plan,
        y: usize,
        sc: &mut Scratch,
        out: &mut [std::mem::MaybeUninit<f32>],
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512vl")
                && std::arch::is_x86_feature_detected!("avx512dq")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: the features were detected at run time.
                unsafe { stages_avx512::<C>(s, d, plan, y, sc) };
            } else if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: the features were detected at run time.
                unsafe { stages_avx2::<C>(s, d, plan, y, sc) };
                unsafe { taps_avx2::<C>(s, sc) };
            } else {
                stages::<C>(s, d, plan, y, sc);
                taps::<C>(s, sc);
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            stages::<C>(s, d, plan, y, sc);
            taps::<C>(s, sc);
        }
        let black = d.outside == Outside::Black;
        let data = s.data;
        let row = s.w * C;
        // How far ahead (in texels) the source lines are prefetched: the gathers wait on the
        // last-level cache otherwise (their addresses are known a whole row in advance).
        const AHEAD: usize = 64;
        for (x, px) in out.chunks_exact_mut(C).enumerate() {
            #[cfg(target_arch = "x86_64")]
            if let Some(&j) = sc.idx.get(x + AHEAD) {
                if j != SLOW {
                    use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
                    let p = data.as_ptr().wrapping_add(j as usize);
                    // SAFETY: prefetching is a hint; it never faults, whatever the address.
                    unsafe {
                        _mm_prefetch::<_MM_HINT_T0>(p as *const i8);
                        _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(row) as *const i8);
                        // The taps' last values (on the next line 2C/16 of the time).
                        _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(2 * C - 1) as *const i8);
                        _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(row + 2 * C - 1) as *const i8);
                    }
                }
            }
            if black && !sc.on[x] {
                px.iter_mut().for_each(|v| {
                    v.write(0.0);
                });
                continue;
            }
            let i00 = sc.idx[x];
            if i00 == SLOW {
                let mut acc = [0.0f32; C];
                s.lookup([sc.p[0][x], sc.p[1][x]], 1.0, &mut acc);
                for k in 0..C {
                    px[k].write(acc[k]);
                }
                continue;
            }
            let (ax, ay) = (sc.frac[0][x], sc.frac[1][x]);
            let i00 = i00 as usize;
            let i01 = i00 + row;
            debug_assert!(i01 + 2 * C <= data.len());
            for k in 0..C {
                // SAFETY: pass 2b gave an index only where 0 ≤ x0 < w − 1 and 0 ≤ y0 < h − 1,
                // which keeps all four taps in the w×h×C slice.
                let (a, b, c, d) = unsafe {
                    (
                        *data.get_unchecked(i00 + k),
                        *data.get_unchecked(i00 + C + k),
                        *data.get_unchecked(i01 + k),
                        *data.get_unchecked(i01 + C + k),
                    )
                };
                let top = a + ax * (b - a);
                let bot = c + ax * (d - c);
                px[k].write(top + ay * (bot - top));
            }
        }
    }
}
