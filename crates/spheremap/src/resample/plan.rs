//! How filtered sampling is planned: a texel's footprint in the source, its strata and the
//! prefiltered level its samples read, the rows they reach, and the memory the levels take.

use super::dest::Dst;
use super::jitter::strata;
use super::options::ResampleOptions;
use super::pyramid;
use super::source::Src;
use crate::base::error::Result;
use crate::base::real::Real;

/// The most memory the prefiltered levels may take to be built whole, without measuring
/// which rows the footprints reach (a 4096×2048 RGB lat-long's pyramid is 32 MiB).
pub(crate) const SMALL_PYRAMID: u128 = 32 << 20;

/// The memory check of a filtered conversion: the output (and as much again for whoever
/// encodes it), plus the levels.
pub(crate) fn check_memory_filtered(
    out_values: usize,
    levels: u128,
    opts: &ResampleOptions,
) -> Result<()> {
    crate::base::limits::check_memory("size", 2 * out_values as u128 * 4 + levels, opts.max_memory)
}

/// The strata count's slack, in source texels: a footprint a thousandth of a texel over an
/// integer n gets n strata per axis (see [`Sampling::plan`]).
pub(crate) const SLACK: f64 = 1e-3;

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
    pub(crate) fn new(opts: &ResampleOptions, depth: usize) -> Self {
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
pub(crate) fn footprint<T: Real>(
    s: &Src<T>,
    d: &Dst<T>,
    x: usize,
    y: usize,
) -> (f64, f64, f64, f64) {
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
pub(crate) fn reach(lo: f64, hi: f64, sp: &Sampling) -> (f64, f64) {
    let m = 2.0 * sp.radius * (hi - lo) + 2.0;
    (lo - m, hi + m)
}

/// Marks the levels and rows that texel (x, y) reads.
#[inline]
pub(crate) fn mark_need(need: &pyramid::Need, lambda: f64, rows: (f64, f64)) {
    if lambda > 0.0 {
        let l0 = lambda.floor() as usize;
        need.mark(l0, rows.0, rows.1);
        if lambda > l0 as f64 {
            need.mark(l0 + 1, rows.0, rows.1);
        }
    }
}
