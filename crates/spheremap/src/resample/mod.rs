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
use crate::images::Image;
use crate::mappings::mapping::Mapping;
use rayon::prelude::*;
use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

mod dest;
pub mod energy;
mod env;
mod filtered;
mod gather;
mod jitter;
mod kernels;
mod lanes;
mod options;
pub mod peaks;
mod plan;
mod pyramid;
mod rows;
mod source;

pub(crate) use dest::Dst;
pub use env::EnvMap;
pub(crate) use jitter::{jitter, strata};
use kernels::{row_filtered, row_single};
pub(crate) use options::check_rotation;
pub use options::{
    Filter, Outside, Precision, Progress, ResampleOptions, ResampleReport, Taps, DEFAULT_SAMPLES,
};
use plan::{check_memory_filtered, footprint, mark_need, reach, Sampling, SMALL_PYRAMID};
pub use source::Sampler;
use source::Src;

/// The rotation that does nothing.
pub use crate::base::vec::IDENTITY3 as IDENTITY;

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
