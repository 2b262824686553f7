//! The filtered path for f32 (`samples` > 1): the same sampling as [`super::row_filtered`]
//! (same footprints, strata, jitter hash, levels and weights), laid out for vectors.
//!
//! A row is done in passes over all its texels at once: first the footprints (the texels'
//! edge midpoints through passes 1–2 of [`super::rows`]), giving each texel its strata and
//! level; then, for each stratum (i, j) of the common g×g grid, one sample per texel through
//! passes 1–2b and a gather that accumulates into the texel.  Texels whose footprint asks for
//! more strata than the common grid (only when `max_samples` allows more than `samples`) are
//! done one by one by the generic code.

use super::rows::{
    bilerp, passes, prefetch, taps_levels, vectorized, LevelTab, Plan, Points, Scratch, Taps,
    AHEAD, SLOW,
};
use super::*;

/// `FScratch::l1` of a texel that reads one level.
const NONE: u8 = u8::MAX;

/// Per-thread buffers of the filtered path for a row of `w` texels.
pub(crate) struct FScratch {
    /// Footprint points: the 3w + 1 edge midpoints of a row.
    fp: Scratch,
    /// One sample per texel.
    sc: Scratch,
    pub(crate) lx: Vec<f64>,
    pub(crate) ly: Vec<f64>,
    pub(crate) lo: Vec<f64>,
    pub(crate) hi: Vec<f64>,
    lambda: Vec<f64>,
    grid: Vec<bool>,
    /// The two levels a texel reads (`NONE`: none) and the weight of the upper one.
    l0: Vec<u8>,
    /// `l0` with NONE for level 0 (those lanes read pass 2b's own result).
    l0s: Vec<u8>,
    l1: Vec<u8>,
    frac: Vec<f32>,
    /// Pass 2b at those levels (level 0 uses the scratch's own).
    lo_f: [Vec<f32>; 2],
    lo_idx: Vec<u32>,
    hi_f: [Vec<f32>; 2],
    hi_idx: Vec<u32>,
    wt: Vec<f32>,
    acc: Vec<f32>,
    wsum: Vec<f32>,
}

impl FScratch {
    pub(crate) fn new(w: usize, c: usize) -> Self {
        FScratch {
            fp: Scratch::new(3 * w + 1),
            sc: Scratch::new(w),
            lx: vec![0.0; w],
            ly: vec![0.0; w],
            lo: vec![0.0; w],
            hi: vec![0.0; w],
            lambda: vec![0.0; w],
            grid: vec![false; w],
            l0: vec![0; w],
            l0s: vec![NONE; w],
            l1: vec![NONE; w],
            frac: vec![0.0; w],
            lo_f: [vec![0.0; w], vec![0.0; w]],
            lo_idx: vec![SLOW; w],
            hi_f: [vec![0.0; w], vec![0.0; w]],
            hi_idx: vec![SLOW; w],
            wt: vec![1.0; w],
            acc: vec![0.0; w * c],
            wsum: vec![0.0; w],
        }
    }
}

/// The footprints of row `y`'s texels into `f.lx`, `f.ly` (source texels across the texel
/// along the canvas axes) and `f.lo`, `f.hi` (the source rows its edge midpoints reach).
pub(crate) fn footprints<const C: usize>(
    s: &Src<f32>,
    d: &Dst<f32>,
    plan: &Plan,
    y: usize,
    f: &mut FScratch,
) {
    let w = f.lx.len();
    let fp = &mut f.fp;
    let (yc, yt, yb) = (y as f32 + 0.5, y as f32, y as f32 + 1.0);
    {
        let [px, py] = &mut fp.pts;
        for x in 0..=w {
            px[x] = x as f32;
            py[x] = yc;
        }
        for x in 0..w {
            px[w + 1 + x] = x as f32 + 0.5;
            py[w + 1 + x] = yt;
            px[2 * w + 1 + x] = x as f32 + 0.5;
            py[2 * w + 1 + x] = yb;
        }
    }
    passes::<C>(s, d, plan, Points::At, fp);
    let dir = |i: usize| [fp.d[0][i], fp.d[1][i], fp.d[2][i]];
    let pos = |i: usize| [fp.p[0][i], fp.p[1][i]];
    for x in 0..w {
        let (l, r, t, b) = (x, x + 1, w + 1 + x, 2 * w + 1 + x);
        f.lx[x] = s.span(pos(l), pos(r), dir(l), dir(r));
        f.ly[x] = s.span(pos(t), pos(b), dir(t), dir(b));
        let ys = [l, r, t, b].map(|i| fp.p[1][i] as f64);
        f.lo[x] = ys.iter().fold(f64::INFINITY, |a, &v| a.min(v));
        f.hi[x] = ys.iter().fold(f64::NEG_INFINITY, |a, &v| a.max(v));
    }
}

/// Row `y` of a filtered conversion; returns (lookups, the most samples a texel took).
#[allow(clippy::too_many_arguments)]
pub(crate) fn row<const C: usize>(
    levels: &[Src<f32>],
    tab: &LevelTab,
    d: &Dst<f32>,
    plan: &Plan,
    y: usize,
    f: &mut FScratch,
    out: &mut [std::mem::MaybeUninit<f32>],
    opts: &ResampleOptions,
    sp: &Sampling,
) -> (u64, usize) {
    let s = &levels[0];
    let w = f.lx.len();
    footprints::<C>(s, d, plan, y, f);
    let (gx, gy) = sp.grid;
    let mut max_n = 0;
    let mut lookups = 0u64;
    let top = levels.len() - 1;
    let mut deepest = 0;
    for x in 0..w {
        let (nx, ny, lambda) = sp.plan(f.lx[x], f.ly[x]);
        f.grid[x] = (nx, ny) == (gx, gy);
        f.lambda[x] = lambda;
        // The levels around λ, as `lookup_lod` reads them.
        let l0 = (lambda.max(0.0).floor() as usize).min(top);
        let fr = if l0 < top { lambda - l0 as f64 } else { 0.0 };
        f.l0[x] = l0 as u8;
        f.l0s[x] = if l0 > 0 && f.grid[x] { l0 as u8 } else { NONE };
        f.frac[x] = if fr > 0.0 { fr as f32 } else { 0.0 };
        f.l1[x] = if fr > 0.0 && f.grid[x] {
            (l0 + 1) as u8
        } else {
            NONE
        };
        if f.grid[x] {
            deepest = deepest.max(l0 + usize::from(fr > 0.0));
        }
    }
    f.acc.fill(0.0);
    f.wsum.fill(0.0);
    let seed = opts.seed as u32 ^ (opts.seed >> 32) as u32;
    let (r, support) = (sp.radius as f32, sp.support as f32);
    let plain = opts.filter == Filter::Box && !d.weighted;
    let black = d.outside == Outside::Black;
    let data = s.data;
    let row = s.w * C;
    let (yc, yu) = (y as f32 + 0.5, y as u32);
    for j in 0..gy {
        for i in 0..gx {
            let k = (j * gx + i) as u32;
            let sc = &mut f.sc;
            {
                let [px, py] = &mut sc.pts;
                let (kx, ky) = (support / gx as f32, support / gy as f32);
                vectorized(
                    #[inline(always)]
                    || {
                        strata_points(
                            &mut px[..w],
                            &mut py[..w],
                            seed,
                            yu,
                            k,
                            [i, j],
                            [kx, ky],
                            r,
                            yc,
                        )
                    },
                );
            }
            if !plain {
                for x in 0..w {
                    let (sx, sy) = (sc.pts[0][x], sc.pts[1][x]);
                    let (ox, oy) = ((sx - x as f32 - 0.5) as f64, (sy - yc) as f64);
                    f.wt[x] = (opts.filter.weight(ox) * opts.filter.weight(oy) * d.density(sx, sy))
                        as f32;
                }
            }
            passes::<C>(s, d, plan, Points::At, sc);
            // Pass 2b at the levels this row's texels read (lanes at level 0 use the above).
            if deepest > 0 {
                let (p, l0, l1) = (&sc.p, &f.l0s, &f.l1);
                let [lax, lay] = &mut f.lo_f;
                let [hax, hay] = &mut f.hi_f;
                let (lo_idx, hi_idx) = (&mut f.lo_idx, &mut f.hi_idx);
                vectorized(
                    #[inline(always)]
                    || {
                        let lo = Taps {
                            idx: lo_idx,
                            ax: lax,
                            ay: lay,
                        };
                        taps_levels::<C>(s.m, tab, p, l0, lo);
                        let hi = Taps {
                            idx: hi_idx,
                            ax: hax,
                            ay: hay,
                        };
                        taps_levels::<C>(s.m, tab, p, l1, hi);
                    },
                );
            }
            for x in 0..w {
                if let Some(&jn) = sc.idx.get(x + AHEAD) {
                    prefetch::<C>(data, row, jn);
                }
                if !f.grid[x] {
                    continue;
                }
                let wt = f.wt[x];
                f.wsum[x] += wt;
                if black && !sc.on[x] {
                    continue;
                }
                lookups += 1;
                let acc: &mut [f32; C] = (&mut f.acc[x * C..x * C + C]).try_into().unwrap();
                let p = [sc.p[0][x], sc.p[1][x]];
                let (l0, fr) = (f.l0[x] as usize, f.frac[x]);
                if l0 == 0 {
                    let i00 = sc.idx[x];
                    let w0 = wt * (1.0 - fr);
                    if i00 == SLOW {
                        levels[0].lookup(p, w0, acc);
                    } else {
                        let v = bilerp::<C>(data, row, i00, sc.frac[0][x], sc.frac[1][x]);
                        for c in 0..C {
                            acc[c] += w0 * v[c];
                        }
                    }
                } else {
                    let (ax, ay) = (f.lo_f[0][x], f.lo_f[1][x]);
                    level_lookup::<C>(
                        &levels[l0],
                        l0,
                        p,
                        f.lo_idx[x],
                        ax,
                        ay,
                        wt * (1.0 - fr),
                        acc,
                    );
                }
                if fr > 0.0 {
                    let l1 = f.l1[x] as usize;
                    let (ax, ay) = (f.hi_f[0][x], f.hi_f[1][x]);
                    level_lookup::<C>(&levels[l1], l1, p, f.hi_idx[x], ax, ay, wt * fr, acc);
                }
            }
        }
    }
    for (x, px) in out.chunks_exact_mut(C).enumerate() {
        let v: [f32; C] = if f.grid[x] {
            max_n = max_n.max(gx * gy);
            let ws = f.wsum[x];
            std::array::from_fn(|c| if ws > 0.0 { f.acc[x * C + c] / ws } else { 0.0 })
        } else {
            let (nx, ny, lambda) = sp.plan(f.lx[x], f.ly[x]);
            max_n = max_n.max(nx * ny);
            let (v, l) = texel::<f32, C>(levels, d, x, y, opts, sp, (nx, ny, lambda));
            lookups += l;
            v
        };
        for c in 0..C {
            px[c].write(v[c]);
        }
    }
    (lookups, max_n)
}

/// A bilinear lookup at level `k` (`i00`, `ax`, `ay` from pass 2b there), weighted into `acc`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn level_lookup<const C: usize>(
    s: &Src<f32>,
    k: usize,
    p: [f32; 2],
    i00: u32,
    ax: f32,
    ay: f32,
    wt: f32,
    acc: &mut [f32; C],
) {
    if i00 == SLOW {
        let sc = 1.0 / (1u32 << k) as f32;
        s.lookup([p[0] * sc, p[1] * sc], wt, acc);
    } else {
        let v = bilerp::<C>(s.data, s.w * C, i00, ax, ay);
        for c in 0..C {
            acc[c] += wt * v[c];
        }
    }
}

/// Stratum `ij` of every texel of row `yu` (jittered by the hash): canvas points into px, py.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn strata_points(
    px: &mut [f32],
    py: &mut [f32],
    seed: u32,
    yu: u32,
    k: u32,
    [i, j]: [usize; 2],
    [kx, ky]: [f32; 2],
    r: f32,
    yc: f32,
) {
    let (fi, fj) = (i as f32, j as f32);
    for x in 0..px.len().min(py.len()) {
        let h = hash32(seed, x as u32, yu, k);
        // Through i32: exact (< 2¹⁶), and signed conversions vectorize.
        let jx = (h & 0xFFFF) as i32 as f32 * (1.0 / 65536.0);
        let jy = (h >> 16) as i32 as f32 * (1.0 / 65536.0);
        px[x] = x as i32 as f32 + 0.5 - r + (fi + jx) * kx;
        py[x] = yc - r + (fj + jy) * ky;
    }
}
