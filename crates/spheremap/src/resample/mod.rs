//! The conversion engine: any mapping to any mapping, destination-driven, footprint-filtered.
//!
//! ## What one output texel is
//!
//! For output texel (x, y) the engine spreads samples over the support of the reconstruction
//! filter centred on the texel (the texel itself for the default 1-texel **box**; 2 texels wide
//! for **tent**; 3 texels for **gaussian**, σ = ½ texel), on an n_x × n_y grid of strata with one
//! jittered sample in each (deterministic: the jitter is a hash of the texel, the stratum and the
//! seed, mirror-symmetric about the canvas's centre lines: `Mirror`).  Each sample's canvas
//! point becomes a direction (the destination mapping's inverse), turns by the view rotation
//! into the source's frame, and is looked up **bilinearly** in the source with the source's
//! wrap rule (or bicubically, from the 4×4 texels round it: [`Taps::Bicubic`]).  The texel is the weighted mean, the weight of a sample being
//! `filter(dx)·filter(dy)·dω/dA` — the mapping's solid-angle density, so that a box
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

use crate::base::error::{Error, Result};
use crate::base::real::Real;
use crate::frame::conventions::mat3_mul;
use crate::images::Image;
use crate::mappings::cube;
use crate::mappings::mapping::Mapping;
use rayon::prelude::*;
use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

mod dest;
pub mod energy;
mod filtered;
mod gather;
mod lanes;
pub mod peaks;
mod pyramid;
mod rows;
mod source;

pub(crate) use dest::Dst;
use pyramid::{Level, NO_ROW};
use source::Src;

crate::base::named::named_enum! {
    /// Reconstruction filter over the output texel's footprint.
    #[derive(Default)]
    pub enum Filter: "filter" as "filter" {
        /// The 1-texel box: the plain (solid-angle weighted) average over the texel. Default.
        #[default]
        Box = "box",
        /// Tent, radius 1 texel.
        Tent = "tent" | "triangle",
        /// Gaussian, σ = ½ texel, truncated at 1.5 texels.
        Gaussian = "gaussian" | "gauss",
    }
}

impl Filter {
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

crate::base::named::named_enum! {
    /// How each sample reads the source's texels.
    #[derive(Default)]
    pub enum Taps: "taps" as "taps" {
        /// The 2×2 texels round the sample, bilinearly. Default.
        #[default]
        Bilinear = "bilinear",
        /// The 4×4 texels round the sample, Catmull–Rom bicubic (interpolating: a sample on a
        /// texel centre reads that texel alone), its result clamped per channel to the range of
        /// the 2×2 nearest texels (no ringing, no negative values from positive ones).  Sharper
        /// where destination texels are as small as the source's or smaller; read from the
        /// source itself (a footprint wide enough to read a prefiltered level reads it
        /// bilinearly), and bilinearly where the 4×4 texels are not all on the map (a disc's
        /// rim).  It runs on the generic scalar path: 15–30× slower than bilinear's vectorised
        /// one.
        Bicubic = "bicubic" | "catmull-rom",
    }
}

crate::base::named::named_enum! {
    /// What to write where a destination disc mapping has no direction.
    #[derive(Default)]
    pub enum Outside: "fill" as "outside" {
        /// The radial mirror image across the rim (no dark fringe under GPU filtering).
        /// Default.
        #[default]
        Gutter = "gutter",
        /// Zero; rim texels hold their covered fraction.
        Black = "black",
    }
}

crate::base::named::named_enum! {
    /// Arithmetic of the direction computations.
    #[derive(Default)]
    pub enum Precision: "precision" as "precision" {
        #[default]
        F32 = "f32",
        F64 = "f64",
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
    /// How each sample reads the source's texels.
    pub taps: Taps,
    pub outside: Outside,
    /// Row-major rotation taking directions in the destination's frame to the source's frame
    /// (its columns are the destination's +X, +Y, +Z axes in source coordinates); see
    /// [`crate::frame::view`].
    pub rotation: [[f64; 3]; 3],
    pub seed: u64,
    pub precision: Precision,
    /// Refuse a job whose estimated allocation is over this many bytes
    /// ([`crate::base::limits::default_max_memory`]).
    pub max_memory: u64,
    /// Keep the light: with `samples > 1`, texels far brighter than the map's mean are split
    /// off and integrated exactly over the output's texels ([`peaks`]), so the output's power
    /// Σ L·dω is the source's.  Default on; off gives the sampled filter alone.
    pub conserve: bool,
}

/// The default sample count (adaptive, at least 4 per texel).
pub const DEFAULT_SAMPLES: u32 = 4;

impl Default for ResampleOptions {
    fn default() -> Self {
        ResampleOptions {
            samples: DEFAULT_SAMPLES,
            max_samples: 1024,
            filter: Filter::Box,
            taps: Taps::Bilinear,
            outside: Outside::Gutter,
            rotation: IDENTITY,
            seed: 0,
            precision: Precision::F32,
            max_memory: crate::base::limits::default_max_memory(),
            conserve: true,
        }
    }
}

/// The rotation that does nothing.
pub use crate::base::vec::IDENTITY3 as IDENTITY;

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
        Self::from_slice(
            mapping,
            img.width,
            img.height,
            img.channels,
            &img.data,
            what,
        )
    }

    /// The same over borrowed texels (row 0 at the top, channels interleaved), with no copy.
    pub fn from_slice(
        mapping: Mapping,
        width: usize,
        height: usize,
        channels: usize,
        data: &'a [f32],
        what: &str,
    ) -> Result<Self> {
        mapping.size_of(width, height, what)?;
        if !(1..=4).contains(&channels) {
            return Err(Error::data(
                what,
                format!("{channels} channels; 1 to 4 are supported"),
            ));
        }
        if data.len() != width * height * channels {
            return Err(Error::data(
                what,
                format!("{} values for {width}×{height}×{channels}", data.len()),
            ));
        }
        Ok(EnvMap {
            mapping,
            width,
            height,
            channels,
            data,
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
    /// The conversion was the identity (same mapping and preset, same canvas, no turn): the
    /// texels were copied ([`is_identity`]).
    pub copied: bool,
    /// Source texels integrated exactly as peaks ([`ResampleOptions::conserve`]).
    pub peak_texels: u64,
}

/// Whether converting `src` into a `width`×`height` canvas of `dst` with `rotation` is the
/// identity: the same mapping and preset, the same canvas size and no turn between the views.
/// Such a conversion copies the texels (no filter or sample count applies), so converting a
/// map to another file format changes only its encoding.
pub fn is_identity(
    src: &EnvMap,
    dst: Mapping,
    width: usize,
    height: usize,
    rotation: &[[f64; 3]; 3],
) -> bool {
    let turned = (0..3).any(|i| (0..3).any(|j| (rotation[i][j] - IDENTITY[i][j]).abs() > 1e-12));
    src.mapping == dst && src.width == width && src.height == height && !turned
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
    let n = width
        .checked_mul(height)
        .and_then(|v| v.checked_mul(src.channels))
        .ok_or_else(|| Error::param("size", "too large"))?;
    check_job(src, dst, width, height, opts)?;
    let mut data: Vec<f32> = crate::base::buffer::with_capacity(n);
    let report = resample_uninit(src, dst, width, height, opts, progress, {
        &mut data.spare_capacity_mut()[..n]
    })?;
    // SAFETY: resample_uninit wrote all n values (every path writes every value of every
    // row, a cancelled row included).
    unsafe { data.set_len(n) };
    let img = Image {
        width,
        height,
        channels: src.channels,
        data,
    };
    Ok((img, report))
}

/// [`resample`] into `out` (`width`·`height`·channels values, row-major, channels last), for
/// callers that reuse one buffer: a fresh output's first touch costs page faults (2–3 ms for
/// 12 MB).  On an error or a cancel, `out`'s contents are unspecified.
pub fn resample_into(
    src: &EnvMap,
    dst: Mapping,
    width: usize,
    height: usize,
    opts: &ResampleOptions,
    progress: Option<&Progress>,
    out: &mut [f32],
) -> Result<ResampleReport> {
    let n = width as u128 * height as u128 * src.channels as u128;
    if out.len() as u128 != n {
        return Err(Error::param(
            "out",
            format!(
                "holds {} values; a {width}x{height}x{} result needs {n}",
                out.len(),
                src.channels
            ),
        ));
    }
    check_job(src, dst, width, height, opts)?;
    // SAFETY: f32 and MaybeUninit<f32> have the same layout, and only initialized values are
    // ever written through the view.
    let view = unsafe { &mut *(out as *mut [f32] as *mut [MaybeUninit<f32>]) };
    resample_uninit(src, dst, width, height, opts, progress, view)
}

/// The checks before a conversion starts.
fn check_job(
    src: &EnvMap,
    dst: Mapping,
    width: usize,
    height: usize,
    opts: &ResampleOptions,
) -> Result<()> {
    dst.size_of(width, height, "size")
        .map_err(|e| Error::param("size", e.to_string()))?;
    crate::base::limits::check_samples(opts.samples, opts.max_samples)?;
    check_rotation(&opts.rotation)?;
    // The output, and as much again for whoever encodes it.
    crate::base::limits::check_memory(
        "size",
        2 * (width as u128 * height as u128 * src.channels as u128 * 4),
        opts.max_memory,
    )
}

/// The conversion into `out` (checked: `check_job`, and its length); writes every value.
fn resample_uninit(
    src: &EnvMap,
    dst: Mapping,
    w: usize,
    h: usize,
    opts: &ResampleOptions,
    progress: Option<&Progress>,
    out: &mut [MaybeUninit<f32>],
) -> Result<ResampleReport> {
    if is_identity(src, dst, w, h, &opts.rotation) {
        return Ok(copy_identity(src, dst, opts.outside, progress, out));
    }
    // Keeping the light: the smooth part sampled, the peaks integrated after.
    let peaks = if opts.conserve && opts.samples > 1 {
        peaks::split(src)
    } else {
        None
    };
    let smooth;
    let (whole, src) = match peaks.as_ref().and_then(|p| p.smooth.as_ref()) {
        Some(data) => {
            smooth = EnvMap { data, ..*src };
            (src, &smooth)
        }
        None => (src, src),
    };
    let mut report = match (opts.precision, src.channels) {
        (Precision::F32, 1) => run::<f32, 1>(src, dst, w, h, opts, progress, out),
        (Precision::F32, 2) => run::<f32, 2>(src, dst, w, h, opts, progress, out),
        (Precision::F32, 3) => run::<f32, 3>(src, dst, w, h, opts, progress, out),
        (Precision::F32, _) => run::<f32, 4>(src, dst, w, h, opts, progress, out),
        (Precision::F64, 1) => run::<f64, 1>(src, dst, w, h, opts, progress, out),
        (Precision::F64, 2) => run::<f64, 2>(src, dst, w, h, opts, progress, out),
        (Precision::F64, 3) => run::<f64, 3>(src, dst, w, h, opts, progress, out),
        (Precision::F64, _) => run::<f64, 4>(src, dst, w, h, opts, progress, out),
    }?;
    if progress.is_some_and(|p| p.cancel.load(Ordering::Relaxed)) {
        return Err(Error::cancelled("the conversion"));
    }
    if let Some(p) = &peaks {
        // SAFETY: the conversion above wrote every value; f32 and MaybeUninit<f32> share
        // their layout.
        let out = unsafe { &mut *(out as *mut [MaybeUninit<f32>] as *mut [f32]) };
        let (rot, o) = (&opts.rotation, opts.outside);
        match whole.channels {
            1 => {
                peaks::normalize::<1>(p, dst, (w, h), o, out);
                peaks::splat::<1>(p, whole, dst, (w, h), rot, o, out)
            }
            2 => {
                peaks::normalize::<2>(p, dst, (w, h), o, out);
                peaks::splat::<2>(p, whole, dst, (w, h), rot, o, out)
            }
            3 => {
                peaks::normalize::<3>(p, dst, (w, h), o, out);
                peaks::splat::<3>(p, whole, dst, (w, h), rot, o, out)
            }
            _ => {
                peaks::normalize::<4>(p, dst, (w, h), o, out);
                peaks::splat::<4>(p, whole, dst, (w, h), rot, o, out)
            }
        }
        report.peak_texels = p.len() as u64;
    }
    Ok(report)
}

/// The identity conversion ([`is_identity`]): every texel copied, except that with
/// [`Outside::Black`] the texels of a disc mapping that lie wholly off the map are zero.
fn copy_identity(
    src: &EnvMap,
    dst: Mapping,
    outside: Outside,
    progress: Option<&Progress>,
    out: &mut [MaybeUninit<f32>],
) -> ResampleReport {
    let (w, c) = (src.width, src.channels);
    let black = outside == Outside::Black && dst.has_outside();
    out.par_chunks_mut(w * c)
        .zip(src.data.par_chunks(w * c))
        .enumerate()
        .for_each(|(y, (row, from))| {
            for (x, (o, i)) in row.chunks_mut(c).zip(from.chunks(c)).enumerate() {
                let off = black && dst.texel_solid_angle(x, y, w, src.height) == 0.0;
                for (o, &v) in o.iter_mut().zip(i) {
                    o.write(if off { 0.0 } else { v });
                }
            }
        });
    if let Some(p) = progress {
        p.done.store(src.height, Ordering::Relaxed);
    }
    ResampleReport {
        lookups: 0,
        max_texel_samples: 0,
        copied: true,
        peak_texels: 0,
    }
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

/// Fills `out` (`w`×`h`×`c`) with rows that `row(scratch, y, row)` writes in parallel (every
/// value of its row), with progress and cancellation (a cancelled row is zero-filled).  The
/// output need not be zeroed first: that pass alone cost 5–13 % of a one-sample job.
#[allow(clippy::too_many_arguments)]
fn fill_rows<S>(
    out: &mut [MaybeUninit<f32>],
    w: usize,
    c: usize,
    min_rows: usize,
    progress: Option<&Progress>,
    scratch: impl Fn() -> S + Send + Sync,
    row: impl Fn(&mut S, usize, &mut [MaybeUninit<f32>]) + Send + Sync,
) {
    out.par_chunks_mut(w * c)
        .enumerate()
        .with_min_len(min_rows)
        .for_each_init(scratch, |sc, (y, out)| {
            if progress.is_some_and(|p| p.cancel.load(Ordering::Relaxed)) {
                out.iter_mut().for_each(|v| {
                    v.write(0.0);
                });
                return;
            }
            row(sc, y, out);
            if let Some(p) = progress {
                p.done.fetch_add(1, Ordering::Relaxed);
            }
        });
}

/// [`fill_rows`] two rows at a time: `pair(scratch, y, row y, Some(row h − 1 − y))` for
/// y < h/2, and for an odd h, `pair(scratch, h/2, middle row, None)`.
fn fill_row_pairs<S, P>(
    out: &mut [MaybeUninit<f32>],
    w: usize,
    c: usize,
    progress: Option<&Progress>,
    scratch: impl Fn() -> S + Send + Sync,
    pair: P,
) where
    P: Fn(&mut S, usize, &mut [MaybeUninit<f32>], Option<&mut [MaybeUninit<f32>]>) + Send + Sync,
{
    let n = w * c;
    if n == 0 {
        return;
    }
    let h = out.len() / n;
    let (top, rest) = out.split_at_mut(h / 2 * n);
    let (middle, bottom) = rest.split_at_mut((h % 2) * n);
    let cancelled = || progress.is_some_and(|p| p.cancel.load(Ordering::Relaxed));
    let zero = |r: &mut [MaybeUninit<f32>]| {
        r.iter_mut().for_each(|v| {
            v.write(0.0);
        })
    };
    top.par_chunks_mut(n)
        .zip(bottom.par_chunks_mut(n).rev())
        .enumerate()
        .with_min_len(2)
        .for_each_init(&scratch, |sc, (y, (a, b))| {
            if cancelled() {
                zero(a);
                zero(b);
                return;
            }
            pair(sc, y, a, Some(b));
            if let Some(p) = progress {
                p.done.fetch_add(2, Ordering::Relaxed);
            }
        });
    if !middle.is_empty() {
        if cancelled() {
            zero(middle);
        } else {
            pair(&mut scratch(), h / 2, middle, None);
            if let Some(p) = progress {
                p.done.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
}

/// The f32 views of a source and a destination when T is f32 (the vectorized paths).
fn as_f32<'x, 'a, T: Real>(
    s: &'x Src<'a, T>,
    d: &'x Dst<T>,
) -> Option<(&'x Src<'a, f32>, &'x Dst<f32>)> {
    if std::any::TypeId::of::<T>() != std::any::TypeId::of::<f32>() || s.cubic {
        return None;
    }
    // SAFETY: T is f32 (the TypeId check above), so Src<T>/Dst<T> are Src<f32>/Dst<f32>.
    unsafe {
        Some((
            &*(s as *const Src<T> as *const Src<f32>),
            &*(d as *const Dst<T> as *const Dst<f32>),
        ))
    }
}

fn run<T: Real, const C: usize>(
    src: &EnvMap,
    dst: Mapping,
    w: usize,
    h: usize,
    opts: &ResampleOptions,
    progress: Option<&Progress>,
    out: &mut [MaybeUninit<f32>],
) -> Result<ResampleReport> {
    let s = Src::<T>::new(src).with_taps(opts.taps);
    let d = Dst::<T>::new(dst, w, h, &opts.rotation, opts.outside);
    if let Some(p) = progress {
        p.total.store(h, Ordering::Relaxed);
    }
    let lookups = AtomicU64::new(0);
    let max_n = AtomicUsize::new(0);
    // The vectorized one-sample path (f32 only).
    if let (1, Some((s32, d32))) = (opts.samples, as_f32(&s, &d)) {
        let plan = rows::Plan::new(s32, d32, &opts.rotation, w);
        if plan.fold[1].is_some() {
            // Rows y and h − 1 − y together: the second's positions are the first's folded.
            fill_row_pairs(
                out,
                w,
                C,
                progress,
                || rows::Scratch::new(w),
                |sc, y, row, mirror| rows::row::<C>(s32, d32, &plan, y, sc, row, mirror),
            );
        } else {
            fill_rows(
                out,
                w,
                C,
                4,
                progress,
                || rows::Scratch::new(w),
                |sc, y, row| rows::row::<C>(s32, d32, &plan, y, sc, row, None),
            );
        }
        let report = ResampleReport {
            lookups: (w * h) as u64,
            max_texel_samples: 1,
            copied: false,
            peak_texels: 0,
        };
        return Ok(report);
    }
    // Filtered: the prefiltered levels this run reads, measured from every texel's footprint
    // first (the same `footprint`/`plan` as the sampling below).
    let depth_max = if opts.samples > 1 {
        pyramid::max_depth(src.mapping, src.width, src.height)
    } else {
        0
    };
    let mut sp = Sampling::new(opts, depth_max);
    let mut built = vec![];
    let whole = pyramid::Need::everything(src.mapping, depth_max, src.height);
    let whole_bytes = whole.bytes(src, depth_max);
    if depth_max > 0
        && whole_bytes <= SMALL_PYRAMID
        && check_memory_filtered(w * h * C, whole_bytes, opts).is_ok()
    {
        // A small source: its whole pyramid costs less memory than the pre-pass costs time
        // (the pre-pass measures every footprint; the results are the same either way, as
        // no texel's λ exceeds the deepest level the pre-pass would mark).  Within a tight
        // `max_memory`, the pre-pass below builds only what is read.
        built = pyramid::build(src, &whole, depth_max);
    } else if depth_max > 0 {
        let need = pyramid::Need::new(src.mapping, depth_max, src.height);
        if let Some((s32, d32)) = as_f32(&s, &d) {
            // The vectorized path's own footprints (what its sampling will use).
            let plan = rows::Plan::new(s32, d32, &opts.rotation, w);
            (0..h).into_par_iter().with_min_len(4).for_each_init(
                || filtered::FScratch::new(w, sp.grid),
                |f, y| {
                    filtered::footprints::<C>(s32, d32, &plan, y, f);
                    for x in 0..w {
                        let (_, _, lambda) = sp.plan(f.lx[x], f.ly[x]);
                        mark_need(&need, lambda, reach(f.lo[x], f.hi[x], &sp));
                    }
                },
            );
        } else {
            (0..h).into_par_iter().with_min_len(4).for_each(|y| {
                for x in 0..w {
                    let (lx, ly, lo, hi) = footprint(&s, &d, x, y);
                    let (_, _, lambda) = sp.plan(lx, ly);
                    mark_need(&need, lambda, reach(lo, hi, &sp));
                }
            });
        }
        sp.depth = need.depth();
        check_memory_filtered(w * h * C, need.bytes(src, sp.depth), opts)?;
        built = pyramid::build(src, &need, sp.depth);
    }
    if let Some((s32, d32)) = as_f32(&s, &d) {
        // The vectorized filtered path.
        let lv32: Vec<Src<f32>> = std::iter::once(Src::new(src))
            .chain(built.iter().map(|l| s32.level(l)))
            .collect();
        let plan = rows::Plan::new(s32, d32, &opts.rotation, w);
        let tab = rows::LevelTab::new::<C>(&lv32);
        let scratch = || filtered::FScratch::new(w, sp.grid);
        let row = |f: &mut _, y, row: &mut _, mirror: Option<&mut [MaybeUninit<f32>]>| {
            let (l, m) = filtered::row::<C>(&lv32, &tab, d32, &plan, y, f, row, mirror, opts, &sp);
            lookups.fetch_add(l, Ordering::Relaxed);
            max_n.fetch_max(m, Ordering::Relaxed);
        };
        if plan.fold[1].is_some() {
            // Rows y and h − 1 − y together (see `filtered::row`).
            fill_row_pairs(out, w, C, progress, scratch, row);
        } else {
            fill_rows(out, w, C, 2, progress, scratch, |f, y, r| {
                row(f, y, r, None)
            });
        }
        let report = ResampleReport {
            lookups: lookups.into_inner(),
            max_texel_samples: max_n.into_inner() as u32,
            copied: false,
            peak_texels: 0,
        };
        return Ok(report);
    }
    let levels: Vec<Src<T>> = std::iter::once(Src::new(src).with_taps(opts.taps))
        .chain(built.iter().map(|l| s.level(l)))
        .collect();
    // The generic path zeroes first (a cancelled row is left as zeros).
    out.iter_mut().for_each(|v| {
        v.write(0.0);
    });
    // SAFETY: every value was just initialized; f32 and MaybeUninit<f32> share their layout.
    let out = unsafe { &mut *(out as *mut [MaybeUninit<f32>] as *mut [f32]) };
    out.par_chunks_mut(w * C)
        .enumerate()
        .with_min_len(4)
        .for_each(|(y, row)| {
            if progress.is_some_and(|p| p.cancel.load(Ordering::Relaxed)) {
                return;
            }
            let (l, m) = if opts.samples == 1 {
                row_single::<T, C>(&s, &d, y, row)
            } else {
                row_filtered::<T, C>(&levels, &d, y, row, opts, &sp)
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
        copied: false,
        peak_texels: 0,
    };
    Ok(report)
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

/// The most memory the prefiltered levels may take to be built whole, without measuring
/// which rows the footprints reach (a 4096×2048 RGB lat-long's pyramid is 32 MiB).
const SMALL_PYRAMID: u128 = 32 << 20;

/// The memory check of a filtered conversion: the output (and as much again for whoever
/// encodes it), plus the levels.
fn check_memory_filtered(out_values: usize, levels: u128, opts: &ResampleOptions) -> Result<()> {
    crate::base::limits::check_memory("size", 2 * out_values as u128 * 4 + levels, opts.max_memory)
}

/// The strata count's slack, in source texels: a footprint a thousandth of a texel over an
/// integer n gets n strata per axis (see [`Sampling::plan`]).
const SLACK: f64 = 1e-3;

/// The per-run constants of filtered sampling.
#[derive(Clone, Copy)]
pub(crate) struct Sampling {
    /// Filter half-width and support (2 × radius), in output texels.
    pub(crate) radius: f64,
    pub(crate) support: f64,
    /// Strata per axis at least (⌈√samples⌉), samples at least, samples at most.
    pub(crate) base: usize,
    pub(crate) samples: usize,
    pub(crate) cap: usize,
    /// Deepest prefiltered level available (0: none).
    pub(crate) depth: usize,
    /// The common strata grid: ⌈√samples⌉ per axis, grown to `samples`, within `cap`.
    pub(crate) grid: (usize, usize),
}

impl Sampling {
    fn new(opts: &ResampleOptions, depth: usize) -> Self {
        let radius = opts.filter.radius();
        let base = (opts.samples as f64).sqrt().ceil() as usize;
        let (samples, cap) = (opts.samples as usize, opts.max_samples as usize);
        Sampling {
            radius,
            support: 2.0 * radius,
            base,
            samples,
            cap,
            depth,
            grid: strata(base, base, samples, cap),
        }
    }

    /// A texel's strata and level from its footprint `lx`×`ly` (source texels across it).
    /// Each axis gets a sample per source texel its support crosses, within `cap` in all;
    /// where that leaves samples more than one source texel apart, they read the level
    /// where they are one texel apart: λ = log₂(spacing), clamped to the pyramid.
    #[inline]
    pub(crate) fn plan(&self, lx: f64, ly: f64) -> (usize, usize, f64) {
        let (nx, ny) = if self.fixed() {
            // No room for more samples than the common grid: it stays, the levels cover.
            self.grid
        } else {
            // A thousandth of a texel of slack: an integer ratio (a 32× shrink), measured as
            // 32.0000001 in one precision and 32 in the other, must not get 33 strata in one
            // path and 32 in the other (they would then sample differently).
            let per_axis = |l: f64| self.base.max((l * self.support - SLACK).ceil() as usize);
            strata(per_axis(lx), per_axis(ly), self.samples, self.cap)
        };
        (nx, ny, self.lambda(self.spacing(lx, ly, nx, ny)))
    }

    /// The common grid is every texel's (`cap` leaves no room for more samples).
    #[inline]
    pub(crate) fn fixed(&self) -> bool {
        self.cap <= self.grid.0 * self.grid.1
    }

    /// How many source texels apart a footprint's nx×ny samples lie (the larger axis).
    #[inline(always)]
    pub(crate) fn spacing(&self, lx: f64, ly: f64, nx: usize, ny: usize) -> f64 {
        (lx * self.support / nx as f64).max(ly * self.support / ny as f64)
    }

    /// The level that samples `spacing` source texels apart read.  Up to 1 + [`SLACK`] the
    /// spacing is that of samples a texel apart: the strata count's slack in `plan` leaves
    /// such spacings (2.0005 texels across two strata), and at a level-1 weight ≤ 0.0015
    /// they read level 0 alone — else every texel near an integer footprint would have the
    /// whole of level 1 built for it.
    #[inline]
    pub(crate) fn lambda(&self, spacing: f64) -> f64 {
        if spacing > 1.0 + SLACK {
            spacing.log2().min(self.depth as f64)
        } else {
            0.0
        }
    }
}

/// A texel's footprint: its extent in source texels along the canvas axes (from its edge
/// midpoints) and the source rows its samples may reach.
fn footprint<T: Real>(s: &Src<T>, d: &Dst<T>, x: usize, y: usize) -> (f64, f64, f64, f64) {
    let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
    let pos = |ox: f64, oy: f64| {
        let (dir, _) = d.dir(T::from_f64(cx + ox), T::from_f64(cy + oy));
        (dir, s.position(dir))
    };
    let (dl, pl) = pos(-0.5, 0.0);
    let (dr, pr) = pos(0.5, 0.0);
    let (dt, pt) = pos(0.0, -0.5);
    let (db, pb) = pos(0.0, 0.5);
    let (lx, ly) = (s.span(pl, pr, dl, dr), s.span(pt, pb, dt, db));
    let ys = [pl[1], pr[1], pt[1], pb[1]].map(|v| v.to_f64());
    let (lo, hi) = ys
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    (lx, ly, lo, hi)
}

/// The source rows (level 0, continuous) that samples of a texel whose edge midpoints span
/// rows `lo..hi` may reach: the filter's support around them, with as much again in margin.
#[inline]
fn reach(lo: f64, hi: f64, sp: &Sampling) -> (f64, f64) {
    let m = 2.0 * sp.radius * (hi - lo) + 2.0;
    (lo - m, hi + m)
}

/// Marks the levels and rows that texel (x, y) reads.
fn mark_need(need: &pyramid::Need, lambda: f64, rows: (f64, f64)) {
    if lambda > 0.0 {
        let l0 = lambda.floor() as usize;
        need.mark(l0, rows.0, rows.1);
        if lambda > l0 as f64 {
            need.mark(l0 + 1, rows.0, rows.1);
        }
    }
}

/// Bilinear lookup at level-0 position `p` read at level λ (trilinear between the two levels
/// around it; `levels[0]` is the source itself).
#[inline]
fn lookup_lod<T: Real, const C: usize>(
    levels: &[Src<T>],
    p: [T; 2],
    lambda: f64,
    weight: T,
    acc: &mut [T; C],
) {
    if !(lambda > 0.0) {
        levels[0].lookup(p, weight, acc);
        return;
    }
    let top = levels.len() - 1;
    let l0 = (lambda.floor() as usize).min(top);
    let f = if l0 < top { lambda - l0 as f64 } else { 0.0 };
    let at = |k: usize| {
        let sc = T::from_f64(1.0 / (1u64 << k) as f64);
        [p[0] * sc, p[1] * sc]
    };
    levels[l0].lookup(at(l0), weight * T::from_f64(1.0 - f), acc);
    if f > 0.0 {
        levels[l0 + 1].lookup(at(l0 + 1), weight * T::from_f64(f), acc);
    }
}

/// Footprint-adaptive stratified samples under the filter.
fn row_filtered<T: Real, const C: usize>(
    levels: &[Src<T>],
    d: &Dst<T>,
    y: usize,
    row: &mut [f32],
    opts: &ResampleOptions,
    sp: &Sampling,
) -> (u64, usize) {
    let mut lookups = 0u64;
    let mut max_n = 0usize;
    for (x, px) in row.chunks_exact_mut(C).enumerate() {
        let (lx, ly, _, _) = footprint(&levels[0], d, x, y);
        let plan = sp.plan(lx, ly);
        let (v, l) = texel::<T, C>(levels, d, x, y, opts, sp, plan);
        px.copy_from_slice(&v);
        lookups += l;
        max_n = max_n.max(plan.0 * plan.1);
    }
    (lookups, max_n)
}

/// Texel (x, y) sampled on its `nx`×`ny` strata at level λ; returns it and its lookups.
fn texel<T: Real, const C: usize>(
    levels: &[Src<T>],
    d: &Dst<T>,
    x: usize,
    y: usize,
    opts: &ResampleOptions,
    sp: &Sampling,
    (nx, ny, lambda): (usize, usize, f64),
) -> ([f32; C], u64) {
    let s = &levels[0];
    let (radius, support) = (sp.radius, sp.support);
    let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
    let mut acc = [T::ZERO; C];
    let mut wsum = T::ZERO;
    let mut lookups = 0;
    for j in 0..ny {
        for i in 0..nx {
            let canvas = (d.wf.to_f64() as usize, d.hf.to_f64() as usize);
            let (jx, jy) = jitter_at(opts.seed, (x, y), (i, j), (nx, ny), canvas);
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
            lookup_lod(levels, s.position(dir), lambda, wt, &mut acc);
            lookups += 1;
        }
    }
    let v = std::array::from_fn(|k| {
        if wsum > T::ZERO {
            (acc[k] / wsum).to_f64() as f32
        } else {
            0.0
        }
    });
    (v, lookups)
}

/// Where the jitter of sample (i, j) of texel (x, y), on its nx×ny strata of a w×h canvas,
/// comes from: the pattern is mirror-symmetric about the canvas's centre lines.  A texel in
/// the right half (x > w − 1 − x) takes the jitter of its mirror image w − 1 − x, stratum
/// nx − 1 − i, reflected (1 − jx); one in the bottom half likewise in y.  So texels that
/// mirror each other have mirror-image samples, and where the canvas's mirrors are folds of
/// the source ([`rows::Fold`]: the default view) the filtered path computes a quarter of its
/// samples' positions and folds the rest.  The pattern loses nothing by it: each quadrant's
/// jitter is independent per texel and stratum, as before.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Mirror {
    /// The hash's texel and stratum index (`jc·nx + ic`).
    pub(crate) xc: u32,
    pub(crate) yc: u32,
    pub(crate) kc: u32,
    /// The jitter is reflected in x / in y.
    pub(crate) mx: bool,
    pub(crate) my: bool,
}

/// [`Mirror`] of sample (i, j) of texel (x, y) on nx×ny strata of a w×h canvas.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn mirror(x: u32, y: u32, i: u32, j: u32, nx: u32, ny: u32, w: u32, h: u32) -> Mirror {
    // (x > w − 1 − x without underflow; the middle texel of an odd w is its own image.)
    let (mx, my) = (2 * x + 1 > w, 2 * y + 1 > h);
    let (xc, ic) = if mx {
        (
            w.wrapping_sub(1).wrapping_sub(x),
            nx.wrapping_sub(1).wrapping_sub(i),
        )
    } else {
        (x, i)
    };
    let (yc, jc) = if my {
        (
            h.wrapping_sub(1).wrapping_sub(y),
            ny.wrapping_sub(1).wrapping_sub(j),
        )
    } else {
        (y, j)
    };
    Mirror {
        xc,
        yc,
        kc: jc.wrapping_mul(nx).wrapping_add(ic),
        mx,
        my,
    }
}

/// The jitter in [0, 1]² of sample (i, j) of texel (x, y) on nx×ny strata of a w×h canvas
/// ([`Mirror`]; f64, the generic path's).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn jitter_at(
    seed: u64,
    (x, y): (usize, usize),
    (i, j): (usize, usize),
    (nx, ny): (usize, usize),
    (w, h): (usize, usize),
) -> (f64, f64) {
    let u = |v: usize| v as u32;
    let m = mirror(u(x), u(y), u(i), u(j), u(nx), u(ny), u(w), u(h));
    let (jx, jy) = jitter32(seed, m.xc as usize, m.yc as usize, m.kc as usize);
    (
        if m.mx { 1.0 - jx } else { jx },
        if m.my { 1.0 - jy } else { jy },
    )
}

/// Deterministic jitter in [0,1)² for sample `k` of texel (x, y): a 32-bit integer hash
/// (xor-multiply mixing, "lowbias32"), 16 bits per axis — cheap enough to vectorize.
#[inline(always)]
pub(crate) fn jitter32(seed: u64, x: usize, y: usize, k: usize) -> (f64, f64) {
    let h = hash32(
        seed as u32 ^ (seed >> 32) as u32,
        x as u32,
        y as u32,
        k as u32,
    );
    ((h & 0xFFFF) as f64 / 65536.0, (h >> 16) as f64 / 65536.0)
}

#[inline(always)]
pub(crate) fn hash32(seed: u32, x: u32, y: u32, k: u32) -> u32 {
    hash32_mixed(seed ^ x.wrapping_mul(HX) ^ y.wrapping_mul(HY) ^ k.wrapping_mul(HK))
}

/// [`hash32`]'s multipliers of x, y and k.
pub(crate) const HX: u32 = 0x9E37_79B1;
pub(crate) const HY: u32 = 0x85EB_CA77;
pub(crate) const HK: u32 = 0xC2B2_AE3D;

/// [`hash32`] after its inputs are mixed: `seed ^ x·HX ^ y·HY ^ k·HK` (wrapping), which a
/// caller may assemble from precomputed products.
#[inline(always)]
pub(crate) fn hash32_mixed(mut h: u32) -> u32 {
    h ^= h >> 16;
    h = h.wrapping_mul(0x7FEB_352D);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846C_A68B);
    h ^ (h >> 16)
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
