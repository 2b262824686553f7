//! The generic per-texel kernels (any precision, any channel count): one lookup at each texel
//! centre, and footprint-adaptive stratified samples under the filter, read at the level the
//! plan gives.

use super::dest::Dst;
use super::jitter::jitter_at;
use super::options::{Outside, ResampleOptions};
use super::plan::{footprint, Sampling};
use super::source::Src;
use crate::base::real::Real;

/// One lookup at each texel centre.
pub(crate) fn row_single<T: Real, const C: usize>(
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

/// Bilinear lookup at level-0 position `p` read at level λ (trilinear between the two levels
/// around it; `levels[0]` is the source itself).
#[inline]
pub(crate) fn lookup_lod<T: Real, const C: usize>(
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
pub(crate) fn row_filtered<T: Real, const C: usize>(
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
pub(crate) fn texel<T: Real, const C: usize>(
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
