//! The filtered path for f32 (`samples` > 1): the same sampling as [`super::row_filtered`]
//! (same footprints, strata, jitter hash, levels and weights), laid out for vectors.
//!
//! A row is done in passes: first the footprints of all its texels (their edge midpoints
//! through passes 1–2 of [`super::rows`]), giving each texel its strata nx×ny and level; then,
//! a chunk of texels at a time (as many as fit [`FILL`] samples), every sample of every
//! texel in the chunk (texel-major: a texel's samples are consecutive) through passes 1–2b,
//! and a gather ([`super::gather`]) that sums each texel's samples in registers and writes
//! it.  Only texels with more strata than a chunk can hold ([`CHUNK`]: `max_samples` > 1024)
//! go one by one through the generic code.
//!
//! Where the canvas's mirrors fold (`rows::Fold`: the default view of a sphere map or
//! lat-long from a lat-long, or a sphere map from a sphere map), the jitter's mirror
//! symmetry (`super::Mirror`) gives texels that mirror each other mirror-image samples: the
//! chunks then cover the left half of row y only, and each chunk's positions, folded, give
//! its images in the right half and in row h − 1 − y (their taps and gathers are their own).
//! A quarter of the samples go through the passes.

use super::dest::Dst;
use super::gather::{self, gather0, level_lookup, sum_level, Acc};
use super::jitter::{hash32, hash32_mixed, mirror, HK, HX, HY};
use super::kernels::texel;
use super::lanes::Lanes;
use super::options::{Filter, Outside, ResampleOptions};
use super::plan::Sampling;
use super::rows::{
    fold_lanes, passes, positions, prefetch, retap, taps_level, vectorized, Fold, LevelTab, Plan,
    Points, Scratch, Taps, SLOW,
};
use super::source::Src;
use crate::mappings::mapping::Mapping;

/// `FScratch::l1` of a texel that reads one level.
const NONE: u8 = u8::MAX;

/// How many texels ahead the gather prefetches the source (measured: J4 2–3% faster).
const PREFETCH: usize = 4;

/// How many samples a chunk can hold at least (a texel with more strata goes through the
/// generic code).
const CHUNK: usize = 1024;

/// How many samples a chunk is filled to (a texel with more goes alone).  The strata and the
/// passes stream ~60 bytes per sample through their arrays: 23 KiB for 384 samples, which
/// leaves the first-level cache (48 KiB here) room for the source lines that the next
/// chunk's texels, the neighbours of these, read again; 1024 samples (60 KiB) evicted them.
/// Measured (J4, one core): 1024 samples 100.8 ms, 640 98.4, 512 97.6, 384 97.8, 256 100.2;
/// on two cores 384 was the faster of 384 and 512 by 1–2 %.
const FILL: usize = 384;

/// Per-thread buffers of the filtered path for a row of `w` texels and a common grid of
/// gx×gy strata per texel.
pub(crate) struct FScratch {
    /// Footprint points of a row: the w + 1 left/right edge midpoints, then the w bottom
    /// ones (`fp`); the w top ones (`ft`), which are the previous row's bottom ones when
    /// `ft_row` says so (a thread does consecutive rows: a third of the points saved).
    fp: Scratch,
    ft: Scratch,
    ft_row: Option<usize>,
    /// The samples of a chunk, texel-major (`cap` of them).
    sc: Scratch,
    cap: usize,
    /// How many texels on the common grid fill a chunk (the tables below).
    per: usize,
    /// Per sample of a chunk of `per` common-grid texels: its texel t (from the chunk's
    /// first) and t·HX; k·HK for its stratum k = j·gx + i as the hash takes it in a plain,
    /// a mirrored column, a mirrored row, and both (`hash32`'s products, indexed mx + 2·my:
    /// see [`super::Mirror`]); and i, j as floats (so its points are one flat loop).
    pt_t: Lanes<u32>,
    pt_hx: Lanes<u32>,
    pt_hk: [Lanes<u32>; 4],
    /// Per sample: its stratum (i, j), for a chunk that straddles the mirror.
    pt_iu: Lanes<u32>,
    pt_ju: Lanes<u32>,
    pt_i: Lanes<f32>,
    pt_j: Lanes<f32>,
    pub(crate) lx: Vec<f64>,
    pub(crate) ly: Vec<f64>,
    pub(crate) lo: Vec<f64>,
    pub(crate) hi: Vec<f64>,
    /// How far apart a texel's samples lie, in source texels (`Sampling::spacing`).
    spacing: Vec<f64>,
    /// A texel's strata (0 × 0: too many for a chunk; the generic code does it).
    nx: Vec<u32>,
    ny: Vec<u32>,
    /// Where a texel's samples start in its chunk.
    start: Vec<usize>,
    /// The two levels a texel reads (`NONE`: none) and the weight of the upper one.
    l0: Vec<u8>,
    /// `l0` with NONE for level 0 (those lanes read pass 2b's own result).
    l0s: Vec<u8>,
    l1: Vec<u8>,
    frac: Vec<f32>,
    /// Pass 2b at those levels, per sample (level 0 uses the scratch's own).
    lo_f: [Lanes<f32>; 2],
    lo_idx: Lanes<u32>,
    hi_f: [Lanes<f32>; 2],
    hi_idx: Lanes<u32>,
    /// Filter weights per sample (all 1 for the plain box).
    wt: Lanes<f32>,
    /// Per sample of a chunk of texels on their own strata: its texel x, stratum k = j·nx + i
    /// and i, j, and its texel's stratum size (the flat loop of their points reads these).
    st_x: Lanes<u32>,
    st_k: Lanes<u32>,
    st_i: Lanes<f32>,
    st_j: Lanes<f32>,
    st_kx: Lanes<f32>,
    st_ky: Lanes<f32>,
    /// A chunk's level-0 positions, kept while its mirror images fold them
    /// (`Plan::fold`), and an image's texels before they go to their places.
    keep: [Lanes<f32>; 2],
    tmp: Vec<std::mem::MaybeUninit<f32>>,
    /// The chunk's runs of texels at one level (`runs`), for `lo_*` and `hi_*`.
    lo_runs: Vec<(usize, std::ops::Range<usize>)>,
    hi_runs: Vec<(usize, std::ops::Range<usize>)>,
}

impl FScratch {
    pub(crate) fn new(w: usize, (gx, gy): (usize, usize)) -> Self {
        let n = (gx * gy).max(1);
        let per = (FILL / n).clamp(1, w.max(1));
        let cap = (per * n).max(CHUNK);
        let (mut pt_t, mut pt_i, mut pt_j) = (vec![], vec![], vec![]);
        let (mut pt_iu, mut pt_ju, mut pt_hx) = (vec![], vec![], vec![]);
        let mut pt_hk: [Vec<u32>; 4] = Default::default();
        let (gxm, gym) = (gx.max(1), gy.max(1));
        for t in 0..per {
            for k in 0..n {
                let (i, j) = (k % gxm, k / gxm);
                pt_t.push(t as u32);
                pt_hx.push((t as u32).wrapping_mul(HX));
                for (m, hk) in pt_hk.iter_mut().enumerate() {
                    let ic = if m & 1 == 1 { gxm - 1 - i } else { i };
                    let jc = if m & 2 == 2 { gym - 1 - j } else { j };
                    hk.push(((jc * gxm + ic) as u32).wrapping_mul(HK));
                }
                pt_iu.push(i as u32);
                pt_ju.push(j as u32);
                pt_i.push((k % gx.max(1)) as f32);
                pt_j.push((k / gx.max(1)) as f32);
            }
        }
        // The footprint points' columns: the left/right edge midpoints (x), then the bottom
        // ones (x + ½), and the top ones (x + ½); `footprints` sets their rows.
        let (mut fp, mut ft) = (Scratch::new(2 * w + 1), Scratch::new(w));
        for x in 0..=w {
            fp.pts[0][x] = x as f32;
        }
        for x in 0..w {
            fp.pts[0][w + 1 + x] = x as f32 + 0.5;
            ft.pts[0][x] = x as f32 + 0.5;
        }
        FScratch {
            fp,
            ft,
            ft_row: None,
            sc: Scratch::new(cap),
            cap,
            per,
            pt_t: Lanes::from_slice(&pt_t),
            pt_hx: Lanes::from_slice(&pt_hx),
            pt_hk: pt_hk.map(|v| Lanes::from_slice(&v)),
            pt_iu: Lanes::from_slice(&pt_iu),
            pt_ju: Lanes::from_slice(&pt_ju),
            pt_i: Lanes::from_slice(&pt_i),
            pt_j: Lanes::from_slice(&pt_j),
            lx: vec![0.0; w],
            ly: vec![0.0; w],
            lo: vec![0.0; w],
            hi: vec![0.0; w],
            spacing: vec![0.0; w],
            nx: vec![0; w],
            ny: vec![0; w],
            start: vec![0; w],
            l0: vec![0; w],
            l0s: vec![NONE; w],
            l1: vec![NONE; w],
            frac: vec![0.0; w],
            lo_f: [Lanes::new(cap, 0.0), Lanes::new(cap, 0.0)],
            lo_idx: Lanes::new(cap, SLOW),
            hi_f: [Lanes::new(cap, 0.0), Lanes::new(cap, 0.0)],
            hi_idx: Lanes::new(cap, SLOW),
            wt: Lanes::new(cap, 1.0),
            st_x: Lanes::new(cap, 0),
            st_k: Lanes::new(cap, 0),
            st_i: Lanes::new(cap, 0.0),
            st_j: Lanes::new(cap, 0.0),
            st_kx: Lanes::new(cap, 0.0),
            st_ky: Lanes::new(cap, 0.0),
            keep: [Lanes::new(cap, 0.0), Lanes::new(cap, 0.0)],
            // (Room for a chunk of 4-channel texels: at most `cap` of them.)
            tmp: vec![std::mem::MaybeUninit::new(0.0); 4 * cap.max(w)],
            lo_runs: vec![],
            hi_runs: vec![],
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
    let (fp, ft) = (&mut f.fp, &mut f.ft);
    // The points' columns are set once (`FScratch::new`); their rows here.
    if f.ft_row != Some(y) {
        ft.pts[1].fill(y as f32);
        positions::<C>(s, d, plan, Points::At(None), ft);
    }
    let py = &mut fp.pts[1];
    py[..=w].fill(y as f32 + 0.5);
    py[w + 1..2 * w + 1].fill(y as f32 + 1.0);
    positions::<C>(s, d, plan, Points::At(None), fp);
    if matches!(s.m, Mapping::Cube(_)) {
        // Edges across a seam measure angles: `Src::span`, one by one.
        let dir = |sc: &Scratch, i: usize| [sc.d[0][i], sc.d[1][i], sc.d[2][i]];
        let pos = |sc: &Scratch, i: usize| [sc.p[0][i], sc.p[1][i]];
        for x in 0..w {
            let (l, r, b) = (x, x + 1, w + 1 + x);
            f.lx[x] = s.span(pos(fp, l), pos(fp, r), dir(fp, l), dir(fp, r));
            f.ly[x] = s.span(pos(ft, x), pos(fp, b), dir(ft, x), dir(fp, b));
        }
    } else {
        // `Src::span` of the other mappings, in f32 so that it vectorizes (it differs from
        // the f64 sums by rounding only; the strata counts have slack for that).
        let ll = matches!(s.m, Mapping::LatLong(_));
        let (wf, hf) = (s.wf, s.hf);
        let eps = (s.hf as f64 * (1e-6 / std::f64::consts::PI)) as f32;
        let ([px, py], [tx, ty]) = (&fp.p, &ft.p);
        let (lx, ly) = (&mut f.lx[..w], &mut f.ly[..w]);
        // Each point set sliced to w (left, right and bottom midpoints): with every length
        // known to be w, the loop has no bounds checks and vectorizes (indexed as px[x + 1]
        // and px[w + 1 + x] it did not: 75 instructions a texel).
        let (lx_, ly_, rx, ry) = (&px[..w], &py[..w], &px[1..w + 1], &py[1..w + 1]);
        let (bx, by) = (&px[w + 1..2 * w + 1], &py[w + 1..2 * w + 1]);
        let (tx, ty) = (&tx[..w], &ty[..w]);
        vectorized(
            #[inline(always)]
            || {
                // Branch-free (selects and a 0/1 factor), so that it vectorizes: with the
                // pole's test as branches it went lane by lane.  The same values.
                #[inline(always)]
                fn span<const LL: bool>(
                    [ax, ay]: [f32; 2],
                    [bx, by]: [f32; 2],
                    [eps, wf, hf]: [f32; 3],
                ) -> f64 {
                    let dx = (bx - ax).abs();
                    let dx = if LL {
                        // Across the u seam the short way; at a pole, no extent in u.
                        let off = (ay > eps) & (ay < hf - eps) & (by > eps) & (by < hf - eps);
                        dx.min(wf - dx) * (off as i32 as f32)
                    } else {
                        dx
                    };
                    let dy = (by - ay).abs();
                    (dx * dx + dy * dy).sqrt() as f64
                }
                let k = [eps, wf, hf];
                if ll {
                    for x in 0..w {
                        lx[x] = span::<true>([lx_[x], ly_[x]], [rx[x], ry[x]], k);
                        ly[x] = span::<true>([tx[x], ty[x]], [bx[x], by[x]], k);
                    }
                } else {
                    for x in 0..w {
                        lx[x] = span::<false>([lx_[x], ly_[x]], [rx[x], ry[x]], k);
                        ly[x] = span::<false>([tx[x], ty[x]], [bx[x], by[x]], k);
                    }
                }
            },
        );
    }
    let (py, ty) = (&fp.p[1][..2 * w + 1], &ft.p[1][..w]);
    let (yl, yr, yb) = (&py[..w], &py[1..w + 1], &py[w + 1..2 * w + 1]);
    let (lo, hi) = (&mut f.lo[..w], &mut f.hi[..w]);
    vectorized(
        #[inline(always)]
        || {
            for x in 0..w {
                let ys = [yl[x], yr[x], ty[x], yb[x]];
                lo[x] = ys[0].min(ys[1]).min(ys[2].min(ys[3])) as f64;
                hi[x] = ys[0].max(ys[1]).max(ys[2].max(ys[3])) as f64;
            }
        },
    );
    // This row's bottom midpoints are the next row's top ones (the same points: y + 1.0 is
    // exact in f32 for any row a canvas has).
    let bottom = w + 1..2 * w + 1;
    for k in 0..3 {
        ft.d[k].copy_from_slice(&fp.d[k][bottom.clone()]);
    }
    for k in 0..2 {
        ft.p[k].copy_from_slice(&fp.p[k][bottom.clone()]);
    }
    f.ft_row = Some(y + 1);
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
    mut mirror_row: Option<&mut [std::mem::MaybeUninit<f32>]>,
    opts: &ResampleOptions,
    sp: &Sampling,
) -> (u64, usize) {
    let s = &levels[0];
    let w = f.lx.len();
    // The canvas's mirrors that fold (`Plan::fold`; with the jitter's mirror symmetry,
    // texels that mirror each other have mirror-image samples): the chunks then cover the
    // row's left half, and each is folded into its images in the right half and in row
    // h − 1 − y (`mirror_row`).
    let fold_c = plan.fold[0];
    let fold_r = plan.fold[1].filter(|_| mirror_row.is_some());
    let wl = if fold_c.is_some() { w.div_ceil(2) } else { w };
    footprints::<C>(s, d, plan, y, f);
    let (gx, gy) = sp.grid;
    let mut max_n = 0;
    let mut lookups = 0u64;
    let common = plan_row(levels.len() - 1, sp, f);
    let seed = opts.seed as u32 ^ (opts.seed >> 32) as u32;
    let (r, support) = (sp.radius as f32, sp.support as f32);
    let plain = opts.filter == Filter::Box && !d.weighted;
    let black = d.outside == Outside::Black;
    let (yc, yu) = (y as f32 + 0.5, y as u32);
    // The jitter's mirror symmetry (`super::Mirror`): the canvas, and this row's part.
    let (g, canvas) = ((gx as u32, gy as u32), (d.wf as u32, d.hf as u32));
    let my = 2 * yu + 1 > canvas.1;
    let ycu = if my { canvas.1 - 1 - yu } else { yu };
    let avx = gather::has_avx2();
    let mut x1 = 0;
    while x1 < wl {
        // The next chunk: texels x0..x1 whose samples fit.
        let x0 = x1;
        let mut tot = 0;
        let mut uniform = true;
        if common {
            // `per` texels of the common grid (no need to look at each).
            x1 = (x0 + f.per).min(wl);
            let n = gx * gy;
            for (t, b) in f.start[..x1 - x0].iter_mut().enumerate() {
                *b = t * n;
            }
            tot = (x1 - x0) * n;
        }
        while x1 < wl && !common {
            let n = (f.nx[x1] * f.ny[x1]) as usize;
            if tot + n > f.cap || (tot > 0 && tot + n > FILL) {
                break;
            }
            uniform &= (f.nx[x1] as usize, f.ny[x1] as usize) == (gx, gy);
            f.start[x1 - x0] = tot;
            tot += n;
            x1 += 1;
        }
        let cnt = x1 - x0;
        if tot == 0 {
            continue;
        }
        let sc = &mut f.sc;
        // The passes compute this chunk's samples only (whole vectors of 16 lanes).
        sc.set_live((tot + 15) & !15);
        let [px, py] = &mut sc.pts;
        if uniform && cnt <= f.per {
            // All on the common grid: every sample in one flat loop (a short last chunk
            // repeats its last texel).
            let (pt_t, pt_i, pt_j) = (&f.pt_t, &f.pt_i, &f.pt_j);
            let (pt_iu, pt_ju, pt_hx) = (&f.pt_iu, &f.pt_ju, &f.pt_hx);
            let last = (w - 1) as u32;
            let (kx, ky) = (support / gx as f32, support / gy as f32);
            // Which side of the column mirror the chunk's texels lie on: all on the left
            // (2x + 1 ≤ w), all on the right, or both.
            let (xl, xr) = (x0 as u32, (x1 - 1) as u32);
            let side = match (2 * xr < canvas.0, 2 * xl + 1 > canvas.0) {
                (true, _) => Some(false),
                (_, true) => Some(true),
                _ => None,
            };
            let jy_m = if my { 1.0f32 } else { 0.0 };
            let sy = if my { -1.0f32 } else { 1.0 };
            vectorized(
                #[inline(always)]
                || {
                    let m = px.len().min(py.len()).min(pt_t.len());
                    let (px, py) = (&mut px[..m], &mut py[..m]);
                    let (pt_t, pt_i, pt_j) = (&pt_t[..m], &pt_i[..m], &pt_j[..m]);
                    let (pt_iu, pt_ju, pt_hx) = (&pt_iu[..m], &pt_ju[..m], &pt_hx[..m]);
                    // (A lane past the row's end, in a short last chunk, repeats the last
                    // texel: unused.)
                    let base = seed ^ ycu.wrapping_mul(HY);
                    match side {
                        // `jitter_mirrored` from the tables' products, the chunk's side known:
                        // hash32(seed, xc, yc, kc) with xc = x0 + t on the left and
                        // w − 1 − x0 − t on the right.
                        Some(right) => {
                            let hk = &f.pt_hk[right as usize + 2 * my as usize][..m];
                            let (xh, sx) = if right {
                                ((canvas.0 - 1 - xl).wrapping_mul(HX), -1.0f32)
                            } else {
                                (xl.wrapping_mul(HX), 1.0)
                            };
                            let jx_m = if right { 1.0f32 } else { 0.0 };
                            for p in 0..m {
                                let x = (xl + pt_t[p]).min(last);
                                let xch = if right {
                                    xh.wrapping_sub(pt_hx[p])
                                } else {
                                    xh.wrapping_add(pt_hx[p])
                                };
                                let (jx, jy) = jitter_f32(hash32_mixed(base ^ xch ^ hk[p]));
                                // (1 − j where mirrored, as a multiply-add: exact.)
                                let (jx, jy) = (jx_m + sx * jx, jy_m + sy * jy);
                                px[p] = x as i32 as f32 + 0.5 - r + (pt_i[p] + jx) * kx;
                                py[p] = yc - r + (pt_j[p] + jy) * ky;
                            }
                        }
                        None => {
                            for p in 0..m {
                                let x = (xl + pt_t[p]).min(last);
                                let (i, j) = (pt_iu[p], pt_ju[p]);
                                let (jx, jy) = jitter_mirrored(seed, x, yu, i, j, g, canvas);
                                px[p] = x as i32 as f32 + 0.5 - r + (pt_i[p] + jx) * kx;
                                py[p] = yc - r + (pt_j[p] + jy) * ky;
                            }
                        }
                    }
                },
            );
        } else {
            // Texels on their own strata (the same formulas): each sample's texel, stratum
            // and stratum size into tables, then every sample in one flat loop that
            // vectorizes (texel by texel, the hash went lane by lane; the flat loop took
            // 13 % off the default job's instructions, `bench/instructions.sh`).
            let (nxs, nys, start) = (&f.nx[x0..x1], &f.ny[x0..x1], &f.start[..cnt]);
            let (sx, sk): (&mut [u32], &mut [u32]) = (&mut f.st_x, &mut f.st_k);
            let (si, sj): (&mut [f32], &mut [f32]) = (&mut f.st_i, &mut f.st_j);
            let (skx, sky): (&mut [f32], &mut [f32]) = (&mut f.st_kx, &mut f.st_ky);
            let mx = |t: usize| 2 * (x0 + t) as u32 + 1 > canvas.0;
            for t in 0..cnt {
                let (nx, ny) = (nxs[t] as usize, nys[t] as usize);
                let r = start[t]..start[t] + nx * ny;
                sx[r.clone()].fill((x0 + t) as u32);
                skx[r.clone()].fill(support / nx as f32);
                sky[r.clone()].fill(support / ny as f32);
                if t > 0 && (nxs[t - 1], nys[t - 1], mx(t - 1)) == (nxs[t], nys[t], mx(t)) {
                    // The previous texel's strata (the usual case): copied.
                    let from = start[t - 1]..start[t];
                    sk.copy_within(from.clone(), r.start);
                    si.copy_within(from.clone(), r.start);
                    sj.copy_within(from, r.start);
                    continue;
                }
                let (sk, si, sj) = (&mut sk[r.clone()], &mut si[r.clone()], &mut sj[r]);
                // (Its stratum index in the hash: `Mirror::kc`.)
                let x = (x0 + t) as u32;
                let mut k = 0;
                for j in 0..ny {
                    for i in 0..nx {
                        let kc = mirror(
                            x, yu, i as u32, j as u32, nx as u32, ny as u32, canvas.0, canvas.1,
                        )
                        .kc;
                        (sk[k], si[k], sj[k]) = (kc, i as f32, j as f32);
                        k += 1;
                    }
                }
            }
            vectorized(
                #[inline(always)]
                || {
                    let m = tot.min(px.len()).min(py.len()).min(sx.len());
                    let (px, py, sx, sk) = (&mut px[..m], &mut py[..m], &sx[..m], &sk[..m]);
                    let (si, sj, skx, sky) = (&si[..m], &sj[..m], &skx[..m], &sky[..m]);
                    for q in 0..m {
                        // `jitter_mirrored`, with the stratum's part from the tables.
                        let x = sx[q];
                        let mx = 2 * x + 1 > canvas.0;
                        let xc = if mx { canvas.0 - 1 - x } else { x };
                        let (jx, jy) = jitter_f32(hash32(seed, xc, ycu, sk[q]));
                        let (jx, jy) = (
                            if mx { 1.0 - jx } else { jx },
                            if my { 1.0 - jy } else { jy },
                        );
                        px[q] = sx[q] as i32 as f32 + 0.5 - r + (si[q] + jx) * skx[q];
                        py[q] = yc - r + (sj[q] + jy) * sky[q];
                    }
                },
            );
        }
        if !plain {
            for t in 0..cnt {
                let x = x0 + t;
                let b = f.start[t];
                for q in b..b + (f.nx[x] * f.ny[x]) as usize {
                    let (sx, sy) = (sc.pts[0][q], sc.pts[1][q]);
                    let (ox, oy) = ((sx - x as f32 - 0.5) as f64, (sy - yc) as f64);
                    f.wt[q] = (opts.filter.weight(ox) * opts.filter.weight(oy) * d.density(sx, sy))
                        as f32;
                }
            }
        }
        // The chunk's samples lie within its texels' filter supports (jitter in [0, 1)).
        let (lo, hi) = (x0 as f32 + 0.5 - r, (x1 - 1) as f32 + 0.5 + r);
        let within = [lo, hi, yc - r, yc + r];
        passes::<C>(s, d, plan, Points::At(Some(within)), sc);
        level_taps::<C>(s, tab, f, x0, cnt);
        let k = Chunk {
            x0,
            cnt,
            flat: avx && uniform && plain && !black && (C == 3 || C == 4),
            n: gx * gy,
            plain,
            black,
            avx,
        };
        let (l, m) = gather_chunk::<C>(levels, f, &k, &mut out[x0 * C..(x0 + cnt) * C]);
        lookups += l;
        max_n = max_n.max(m);
        if fold_c.is_none() && fold_r.is_none() {
            continue;
        }
        // The chunk's mirror images (`Plan::fold`): its samples' positions folded, their
        // taps again, and their gathers into the mirrored texels.  The unfolded positions
        // are kept to fold afresh for the row mirror alone.
        let live = ((tot + 15) & !15).min(f.cap);
        for a in 0..2 {
            f.keep[a][..live].copy_from_slice(&f.sc.p[a][..live]);
        }
        let mut image =
            |f: &mut FScratch, fold: Fold, to: &mut [std::mem::MaybeUninit<f32>], rev: bool| {
                fold_lanes(&fold, &mut f.sc);
                retap::<C>(s, &mut f.sc);
                level_taps::<C>(s, tab, f, x0, cnt);
                let mut tmp = std::mem::take(&mut f.tmp);
                let (l, m) = gather_chunk::<C>(levels, f, &k, &mut tmp[..cnt * C]);
                lookups += l;
                max_n = max_n.max(m);
                for t in 0..cnt {
                    let x = if rev { w - 1 - (x0 + t) } else { x0 + t };
                    // (The middle texel of an odd row is its own column image: not again.)
                    if rev && x == x0 + t {
                        continue;
                    }
                    to[x * C..x * C + C].copy_from_slice(&tmp[t * C..t * C + C]);
                }
                f.tmp = tmp;
            };
        if let Some(fc) = fold_c {
            image(f, fc, out, true);
            if let (Some(fr), Some(m)) = (fold_r, mirror_row.as_deref_mut()) {
                image(f, fr, m, true);
            }
            for a in 0..2 {
                f.sc.p[a][..live].copy_from_slice(&f.keep[a][..live]);
            }
        }
        if let (Some(fr), Some(m)) = (fold_r, mirror_row.as_deref_mut()) {
            image(f, fr, m, false);
        }
    }
    // Texels with their own strata, one by one (and their images, on their strata).
    let h = d.hf as usize;
    for x in 0..wl {
        if common || f.nx[x] > 0 {
            continue;
        }
        let plan = sp.plan(f.lx[x], f.ly[x]);
        max_n = max_n.max(plan.0 * plan.1);
        let mut one = |x: usize, y: usize, to: &mut [std::mem::MaybeUninit<f32>]| {
            let (v, l) = texel::<f32, C>(levels, d, x, y, opts, sp, plan);
            lookups += l;
            for c in 0..C {
                to[x * C + c].write(v[c]);
            }
        };
        let xm = w - 1 - x;
        one(x, y, out);
        if fold_c.is_some() && xm != x {
            one(xm, y, out);
        }
        if let (Some(_), Some(m)) = (fold_r, mirror_row.as_deref_mut()) {
            one(x, h - 1 - y, m);
            if fold_c.is_some() && xm != x {
                one(xm, h - 1 - y, m);
            }
        }
    }
    (lookups, max_n)
}

/// Pass 2b at the levels that the deep texels of the chunk `x0..x0 + cnt` read, for the
/// chunk's samples in `f.sc` (level 0 is the passes' own); a run of texels at the same
/// level is one call (their samples are consecutive).
fn level_taps<const C: usize>(
    s: &Src<f32>,
    tab: &LevelTab,
    f: &mut FScratch,
    x0: usize,
    cnt: usize,
) {
    let x1 = x0 + cnt;
    let (nxs, nys, start) = (&f.nx[x0..x1], &f.ny[x0..x1], &f.start[..cnt]);
    runs(&f.l0s[x0..x1], nxs, nys, start, &mut f.lo_runs);
    runs(&f.l1[x0..x1], nxs, nys, start, &mut f.hi_runs);
    if f.lo_runs.is_empty() && f.hi_runs.is_empty() {
        return;
    }
    let p = &f.sc.p;
    let [lax, lay] = &mut f.lo_f;
    let [hax, hay] = &mut f.hi_f;
    let (lo_idx, hi_idx) = (&mut f.lo_idx, &mut f.hi_idx);
    let (lo_runs, hi_runs) = (&f.lo_runs, &f.hi_runs);
    vectorized(
        #[inline(always)]
        || {
            for (k, range) in lo_runs.iter().cloned() {
                let lo = Taps {
                    idx: lo_idx,
                    ax: lax,
                    ay: lay,
                };
                taps_level::<C>(s.m, tab, k, p, range, lo);
            }
            for (k, range) in hi_runs.iter().cloned() {
                let hi = Taps {
                    idx: hi_idx,
                    ax: hax,
                    ay: hay,
                };
                taps_level::<C>(s.m, tab, k, p, range, hi);
            }
        },
    );
}

/// What [`gather_chunk`] sums: the chunk's texels `x0..x0 + cnt`, `n` samples each on the
/// common grid when `flat` (which also says: unit weights, no black outside, C = 3 or 4,
/// AVX2), and how ([`Gather`]).
struct Chunk {
    x0: usize,
    cnt: usize,
    flat: bool,
    n: usize,
    plain: bool,
    black: bool,
    avx: bool,
}

/// The chunk's texels from its samples' taps in `f` into `out` (the chunk's `cnt` texels);
/// returns (lookups, the most samples a texel took).  Runs of texels that read the same
/// levels go through a flat gather when it applies (level 0 alone, the common case:
/// `flat_gather`; else `flat_levels`); the others, texel by texel.
fn gather_chunk<const C: usize>(
    levels: &[Src<f32>],
    f: &FScratch,
    k: &Chunk,
    out: &mut [std::mem::MaybeUninit<f32>],
) -> (u64, usize) {
    let (s, x0, cnt, n) = (&levels[0], k.x0, k.cnt, k.n);
    let (mut lookups, mut max_n) = (0u64, 0);
    let mut t1 = 0;
    while t1 < cnt {
        let t0 = t1;
        let key = |t: usize| (f.l0s[x0 + t], f.l1[x0 + t]);
        t1 += 1;
        while t1 < cnt && (!k.flat || key(t1) == key(t0)) {
            t1 += 1;
        }
        let run_out = &mut out[t0 * C..t1 * C];
        let done = k.flat
            && if key(t0) == (NONE, NONE) {
                flat_gather::<C>(s, &f.sc, n, t0..t1, run_out)
            } else {
                flat_levels::<C>(levels, f, n, x0, t0..t1, run_out)
            };
        if done {
            lookups += (n * (t1 - t0)) as u64;
            max_n = max_n.max(n);
            continue;
        }
        let g = Gather {
            levels,
            f,
            x0,
            t0,
            plain: k.plain,
            black: k.black,
        };
        let (l, m) = if k.avx {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `avx`: this CPU has AVX2 and FMA.
            unsafe {
                gather_avx2::<C>(&g, run_out)
            }
            #[cfg(not(target_arch = "x86_64"))]
            unreachable!()
        } else {
            g.texels::<C, false>(run_out)
        };
        lookups += l;
        max_n = max_n.max(m);
    }
    (lookups, max_n)
}

/// Each texel's strata and levels (`FScratch::nx`, `ny`, `l0`, `l0s`, `l1`, `frac`) from its
/// footprint, as [`Sampling::plan`] gives them; `top` is the deepest level.  Returns whether
/// every texel is on the common grid, which a chunk holds (`FScratch::per` texels of it).
fn plan_row(top: usize, sp: &Sampling, f: &mut FScratch) -> bool {
    let w = f.lx.len();
    // (A function, not a closure: inlined into both loops below; called as a closure it
    // was not, at 2 % of J4.)
    #[inline(always)]
    fn level(f: &mut FScratch, top: usize, x: usize, nx: usize, ny: usize, lambda: f64) {
        let vec = nx * ny <= f.cap;
        (f.nx[x], f.ny[x]) = if vec { (nx as u32, ny as u32) } else { (0, 0) };
        // The levels around λ, as `lookup_lod` reads them.
        // (λ ≥ 0 and finite: truncation is its floor, without a library call; through i64,
        // whose conversions are one instruction each way.)
        let l0 = (lambda.max(0.0) as i64).min(top as i64);
        let fr = if l0 < top as i64 {
            lambda - l0 as f64
        } else {
            0.0
        };
        f.l0[x] = l0 as u8;
        f.l0s[x] = if l0 > 0 && vec { l0 as u8 } else { NONE };
        f.frac[x] = if fr > 0.0 { fr as f32 } else { 0.0 };
        f.l1[x] = if fr > 0.0 && vec {
            (l0 + 1) as u8
        } else {
            NONE
        };
    }
    if !sp.fixed() {
        // (Compiled for the vector extensions: the strata counts' `ceil` is then one
        // instruction, not a library call; the loop itself stays lane by lane.)
        vectorized(
            #[inline(always)]
            || {
                for x in 0..w {
                    let (nx, ny, lambda) = sp.plan(f.lx[x], f.ly[x]);
                    level(f, top, x, nx, ny, lambda);
                }
            },
        );
        return false;
    }
    // Every texel on the common grid: the spacings in one vectorized loop, then only the
    // texels whose samples lie more than a texel apart (the rim; few) take a logarithm.
    let (gx, gy) = sp.grid;
    let (lx, ly, sps) = (&f.lx[..w], &f.ly[..w], &mut f.spacing[..w]);
    vectorized(
        #[inline(always)]
        || {
            for x in 0..w {
                sps[x] = sp.spacing(lx[x], ly[x], gx, gy);
            }
        },
    );
    let fits = gx * gy <= f.cap;
    let (nx, ny) = if fits { (gx as u32, gy as u32) } else { (0, 0) };
    f.nx.fill(nx);
    f.ny.fill(ny);
    f.l0.fill(0);
    f.l0s.fill(NONE);
    f.l1.fill(NONE);
    f.frac.fill(0.0);
    for x in 0..w {
        let lambda = sp.lambda(f.spacing[x]);
        if lambda > 0.0 {
            level(f, top, x, gx, gy, lambda);
        }
    }
    fits
}

/// The runs of consecutive texels (of a chunk) that read the same level `lv[t]` (not
/// `NONE`), as (level, their samples) into `out`.
fn runs(
    lv: &[u8],
    nx: &[u32],
    ny: &[u32],
    start: &[usize],
    out: &mut Vec<(usize, std::ops::Range<usize>)>,
) {
    out.clear();
    let n = lv.len().min(start.len());
    let mut t = 0;
    while t < n {
        let (k, t0) = (lv[t], t);
        while t < n && lv[t] == k {
            t += 1;
        }
        if k != NONE {
            let end = start[t - 1] + (nx[t - 1] * ny[t - 1]) as usize;
            out.push((k as usize, start[t0]..end));
        }
    }
}

/// What the gather of a chunk (texels `x0..`) reads.
struct Gather<'a, 'b> {
    levels: &'a [Src<'b, f32>],
    f: &'a FScratch,
    /// The chunk's first texel, and the first of these (from the chunk's first).
    x0: usize,
    t0: usize,
    /// Unit weights (the box filter on an unweighted canvas).
    plain: bool,
    /// Outside the disc is black (those samples are not looked up).
    black: bool,
}

impl Gather<'_, '_> {
    /// Sums each texel's samples into its value in `out`; returns (lookups, the most samples
    /// a texel took).  `AVX`: the caller is compiled for AVX2 and FMA.
    #[inline(always)]
    fn texels<const C: usize, const AVX: bool>(
        &self,
        out: &mut [std::mem::MaybeUninit<f32>],
    ) -> (u64, usize) {
        let (levels, f, plain, black) = (self.levels, self.f, self.plain, self.black);
        let (s, sc) = (&levels[0], &f.sc);
        let (mut lookups, mut max_n) = (0u64, 0);
        for (t, px) in out.chunks_exact_mut(C).enumerate() {
            let t = self.t0 + t;
            let x = self.x0 + t;
            let n = (f.nx[x] * f.ny[x]) as usize;
            if n == 0 {
                continue;
            }
            max_n = max_n.max(n);
            let b = f.start[t];
            let (l0, fr) = (f.l0[x] as usize, f.frac[x]);
            // The source lines of the texels a few ahead (their level-0 taps; past the
            // chunk's samples these are stale, which costs a hint and no more).
            for q in [b + PREFETCH * n, b + PREFETCH * n + n / 2] {
                if let Some(&j) = sc.idx.get(q) {
                    prefetch::<C>(s.data, s.w * C, j);
                }
            }
            if plain && !black && (AVX || l0 > 0 || fr > 0.0) {
                // Unit weights: each level's lanes summed at once.
                lookups += n as u64;
                let mut acc = Acc::<C>::new();
                let r = b..b + n;
                let (p, w0) = (&sc.p, 1.0 - fr);
                if l0 == 0 {
                    let (i, [ax, ay]) = (&sc.idx, &sc.frac);
                    sum_level::<C, AVX>(s, 0, p, i, ax, ay, r.clone(), w0, &mut acc);
                } else {
                    let (i, [ax, ay]) = (&f.lo_idx, &f.lo_f);
                    let l = &levels[l0];
                    sum_level::<C, AVX>(l, l0, p, i, ax, ay, r.clone(), w0, &mut acc);
                }
                if fr > 0.0 {
                    let l1 = f.l1[x] as usize;
                    let (i, [ax, ay]) = (&f.hi_idx, &f.hi_f);
                    sum_level::<C, AVX>(&levels[l1], l1, p, i, ax, ay, r, fr, &mut acc);
                }
                let v = acc.scaled::<AVX>(1.0 / n as f32);
                for c in 0..C {
                    px[c].write(v[c]);
                }
                continue;
            }
            let mut acc = [0.0f32; C];
            let wsum;
            if l0 == 0 && fr == 0.0 && plain && !black {
                // The same without AVX2, in a 4-lane register.
                lookups += n as u64;
                wsum = n as f32;
                gather0::<C>(s, &sc.p, &sc.idx, &sc.frac, b, n, &mut acc);
            } else {
                let mut ws = 0.0f32;
                for q in b..b + n {
                    let wt = if plain { 1.0 } else { f.wt[q] };
                    ws += wt;
                    if black && !sc.on[q] {
                        continue;
                    }
                    lookups += 1;
                    let p = [sc.p[0][q], sc.p[1][q]];
                    if l0 == 0 {
                        let w0 = wt * (1.0 - fr);
                        let (i, ax, ay) = (sc.idx[q], sc.frac[0][q], sc.frac[1][q]);
                        level_lookup::<C>(s, 0, p, i, ax, ay, w0, &mut acc);
                    } else {
                        let (ax, ay) = (f.lo_f[0][q], f.lo_f[1][q]);
                        let (i, w) = (f.lo_idx[q], wt * (1.0 - fr));
                        level_lookup::<C>(&levels[l0], l0, p, i, ax, ay, w, &mut acc);
                    }
                    if fr > 0.0 {
                        let l1 = f.l1[x] as usize;
                        let (ax, ay) = (f.hi_f[0][q], f.hi_f[1][q]);
                        let i = f.hi_idx[q];
                        level_lookup::<C>(&levels[l1], l1, p, i, ax, ay, wt * fr, &mut acc);
                    }
                }
                wsum = ws;
            }
            for c in 0..C {
                px[c].write(if wsum > 0.0 { acc[c] / wsum } else { 0.0 });
            }
        }
        (lookups, max_n)
    }
}

/// [`Gather::texels`] compiled for AVX2 and FMA.
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn gather_avx2<const C: usize>(
    g: &Gather,
    out: &mut [std::mem::MaybeUninit<f32>],
) -> (u64, usize) {
    g.texels::<C, true>(out)
}

/// The flat gather ([`gather::mean8`]) of the chunk's texels `ts` (on the common grid of `n`
/// samples, all at level 0) into `out`, when all their lanes are plain; else false (and
/// nothing written).
#[inline]
fn flat_gather<const C: usize>(
    s: &Src<f32>,
    sc: &Scratch,
    n: usize,
    ts: std::ops::Range<usize>,
    out: &mut [std::mem::MaybeUninit<f32>],
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if let (3 | 4, true, Some(lim)) = (C, gather::has_avx2(), s.data.len().checked_sub(s.w * C + 8))
    {
        let r = ts.start * n..ts.end * n;
        let [ax, ay] = &sc.frac;
        let (idx, ax, ay) = (&sc.idx[r.clone()], &ax[r.clone()], &ay[r]);
        let lim = lim.min(SLOW as usize - 1);
        // SAFETY: AVX2 and FMA (`has_avx2`); C is 3 or 4.
        return unsafe { mean8_avx2::<C>(s.data, s.w * C, lim, idx, ax, ay, n, out) };
    }
    let _ = (s, sc, n, ts, out);
    false
}

/// The flat gather ([`gather::mean8_levels`]) of the chunk's texels `ts` (from the chunk's
/// first, texel `x0`; on the common grid of `n` samples, all reading the same levels) into
/// `out`, when all their lanes are plain; else false (and nothing written).
#[inline]
fn flat_levels<const C: usize>(
    levels: &[Src<f32>],
    f: &FScratch,
    n: usize,
    x0: usize,
    ts: std::ops::Range<usize>,
    out: &mut [std::mem::MaybeUninit<f32>],
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if (C == 3 || C == 4) && gather::has_avx2() {
        let x = x0 + ts.start;
        let r = ts.start * n..ts.end * n;
        // The lower level: level 0 from the chunk's own pass 2b, a deeper one from `lo_*`.
        let (k0, idx, [ax, ay]) = match f.l0s[x] {
            NONE => (0, &f.sc.idx, &f.sc.frac),
            k => (k as usize, &f.lo_idx, &f.lo_f),
        };
        let lo = gather::LevelTaps {
            data: levels[k0].data,
            row: levels[k0].w * C,
            idx: &idx[r.clone()],
            ax: &ax[r.clone()],
            ay: &ay[r.clone()],
        };
        let hi = match f.l1[x] {
            NONE => None,
            k => {
                let l = &levels[k as usize];
                Some(gather::LevelTaps {
                    data: l.data,
                    row: l.w * C,
                    idx: &f.hi_idx[r.clone()],
                    ax: &f.hi_f[0][r.clone()],
                    ay: &f.hi_f[1][r.clone()],
                })
            }
        };
        let fr = &f.frac[x..x0 + ts.end];
        // SAFETY: AVX2 and FMA (`has_avx2`); C is 3 or 4; the lanes are checked inside.
        return unsafe { mean8_levels_avx2::<C>(lo, hi, fr, n, out) };
    }
    let _ = (levels, f, n, x0, ts, out);
    false
}

/// [`gather::mean8_levels`], compiled for AVX2 and FMA, when every lane of `lo` and `hi`
/// is plain; else false.
///
/// # Safety
/// The CPU has AVX2 and FMA; C is 3 or 4.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn mean8_levels_avx2<const C: usize>(
    lo: gather::LevelTaps,
    hi: Option<gather::LevelTaps>,
    fr: &[f32],
    n: usize,
    out: &mut [std::mem::MaybeUninit<f32>],
) -> bool {
    if !lo.plain() || hi.is_some_and(|h| !h.plain()) {
        return false;
    }
    // SAFETY: as the caller's, and every lane is plain (checked above).
    unsafe { gather::mean8_levels::<C>(lo, hi, fr, n, out) };
    true
}

/// [`gather::mean8`], compiled for AVX2 and FMA, when every lane is plain: its index at
/// most `lim` (the largest decides; SLOW is larger than any plain one); else false.
///
/// # Safety
/// The CPU has AVX2 and FMA; C is 3 or 4; `lim + row + 8 ≤ data.len()`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
unsafe fn mean8_avx2<const C: usize>(
    data: &[f32],
    row: usize,
    lim: usize,
    idx: &[u32],
    ax: &[f32],
    ay: &[f32],
    n: usize,
    out: &mut [std::mem::MaybeUninit<f32>],
) -> bool {
    if idx.iter().fold(0, |m, &v| m.max(v)) as usize > lim {
        return false;
    }
    // SAFETY: as the caller's, and every lane's reads end in the data (checked above).
    unsafe { gather::mean8::<C>(data, row, idx, ax, ay, n, PREFETCH, out) };
    true
}

/// The jitter of sample (i, j) of texel (x, y) on `g` = nx×ny strata of a `canvas` = w×h
/// canvas, mirror-symmetric ([`super::Mirror`]; the values of `jitter_at`, in f32).
#[inline(always)]
fn jitter_mirrored(
    seed: u32,
    x: u32,
    y: u32,
    i: u32,
    j: u32,
    (nx, ny): (u32, u32),
    (w, h): (u32, u32),
) -> (f32, f32) {
    let m = mirror(x, y, i, j, nx, ny, w, h);
    let (jx, jy) = jitter_f32(hash32(seed, m.xc, m.yc, m.kc));
    (
        if m.mx { 1.0 - jx } else { jx },
        if m.my { 1.0 - jy } else { jy },
    )
}

/// The jitter in [0, 1)² of a sample from its hash (16 bits per axis, as `jitter32`).
#[inline(always)]
fn jitter_f32(h: u32) -> (f32, f32) {
    // Through i32: exact (< 2¹⁶), and signed conversions vectorize.
    let jx = (h & 0xFFFF) as i32 as f32 * (1.0 / 65536.0);
    let jy = (h >> 16) as i32 as f32 * (1.0 / 65536.0);
    (jx, jy)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::resample::env::EnvMap;
    use crate::resample::jitter::{jitter32, jitter_at};

    /// A row's footprints are the same whether its top edge points are its own or the
    /// previous row's bottom ones (lat-long: positions; cube: directions too).
    #[test]
    fn footprints_reuse_the_previous_rows_bottom_edge_exactly() {
        use crate::images::Image;
        for (src, n) in [("latlong", 32), ("cube", 16)] {
            let m = Mapping::parse(src, None).unwrap();
            let (sw, sh) = m.canvas(n);
            let img = Image::new(sw, sh, 3);
            let e = EnvMap::new(m, &img, "t").unwrap();
            let s = Src::<f32>::new(&e);
            let rot = crate::frame::view::look_up([0.3, 1.0, -0.2], [0.0, 0.0, 1.0]).unwrap();
            let sp = Mapping::parse("sphere", None).unwrap();
            let w = 40;
            let d = Dst::<f32>::new(sp, w, w, &rot, Outside::Gutter);
            let plan = Plan::new(&s, &d, &rot, w);
            let mut run = FScratch::new(w, (4, 4));
            for y in 0..w {
                footprints::<3>(&s, &d, &plan, y, &mut run);
                assert_eq!(run.ft_row, Some(y + 1));
                let mut fresh = FScratch::new(w, (4, 4));
                footprints::<3>(&s, &d, &plan, y, &mut fresh);
                assert_eq!((&run.lx, &run.ly), (&fresh.lx, &fresh.ly), "{src} row {y}");
                assert_eq!((&run.lo, &run.hi), (&fresh.lo, &fresh.hi), "{src} row {y}");
            }
        }
    }

    /// The jitter is mirror-symmetric: texels that mirror each other about the canvas's
    /// centre lines have mirror-image samples (odd and even canvases; the middle texel of an
    /// odd one is its own image), and the f32 loops' jitter is the generic path's.
    #[test]
    fn the_jitter_is_mirror_symmetric_and_the_same_in_both_paths() {
        for seed in [0u64, 7, 0xDEAD_BEEF_0123] {
            let s32 = seed as u32 ^ (seed >> 32) as u32;
            for (w, h) in [(8usize, 8usize), (7, 5), (64, 32)] {
                for (nx, ny) in [(4usize, 4usize), (3, 2), (1, 5)] {
                    for (y, x) in (0..h).flat_map(|y| (0..w).map(move |x| (y, x))) {
                        for (j, i) in (0..ny).flat_map(|j| (0..nx).map(move |i| (j, i))) {
                            let at = |x, y, i, j| jitter_at(seed, (x, y), (i, j), (nx, ny), (w, h));
                            let (jx, jy) = at(x, y, i, j);
                            let (mx, my) = at(w - 1 - x, h - 1 - y, nx - 1 - i, ny - 1 - j);
                            let (a, b) = (2 * x + 1 == w, 2 * y + 1 == h);
                            if !a && !b {
                                assert_eq!((jx, jy), (1.0 - mx, 1.0 - my), "({x}, {y})");
                            }
                            let u = |v: usize| v as u32;
                            let g = (u(nx), u(ny));
                            let f = jitter_mirrored(s32, u(x), u(y), u(i), u(j), g, (u(w), u(h)));
                            assert_eq!((f.0 as f64, f.1 as f64), (jx, jy));
                            if !a && !b && 2 * x + 1 < w && 2 * y + 1 < h {
                                // The top-left quadrant keeps the plain hash.
                                assert_eq!((jx, jy), jitter32(seed, x, y, j * nx + i));
                            }
                        }
                    }
                }
            }
        }
    }
}
