//! Light that sampling would miss: the source's brightest texels split off and integrated
//! exactly.
//!
//! ## Why
//!
//! The filtered path estimates each output texel's integral from a few jittered, bilinear
//! samples per source texel.  Over smooth radiance that estimate is accurate; over a source
//! texel far brighter than its surroundings (a sun, a softbox, a lamp) it is a hit or a miss:
//! how much of that texel's light the output receives depends on where the samples fell.  A
//! sun texel carrying a tenth of the map's power, over- or under-counted by half, moves the
//! whole output's power by 5 %.
//!
//! ## What
//!
//! The source is split per channel into a **smooth** part, `min(L, r·τ)`, and **peaks**,
//! `L − min(L, r·τ)` (≥ 0, zero almost everywhere), where τ = [`PEAK_RATIO`] × L̄ is a multiple
//! of the map's mean radiance L̄ (Σ L dω / Σ dω) and r = 1 unless more than [`max_peaks`]
//! texels exceed τ (then r grows until that many do).  The smooth part goes through the usual
//! sampled filter: bounded by a small multiple of the mean, its sampling errors stay a small
//! fraction of the map's light.  The peaks are **integrated**: each peak texel is cut into
//! k × k cells (k from the texel's extent on the output canvas: [`CELLS_PER_TEXEL`] cells per
//! output texel it spans, within [`K_MIN`]..=[`K_MAX`]), each cell carries its share of the
//! texel's exact solid angle (the mapping's density at its centre, the shares normalized to
//! the texel's solid angle) to the output texel its centre falls in, and each output texel
//! receives the light it was given divided by its own exact solid angle.  So every peak
//! texel's power Σ L·dω lands whole in the output (to rounding), and an output texel that
//! covers many source texels holds their exact area average (to a cell).
//!
//! The sampled part's total is then normalized to the smooth source's power, channel by
//! channel ([`normalize`]): what sampling leaves (a fraction of a percent, mostly where a
//! disc's rim texels span a wide range of directions) becomes a uniform gain instead of a
//! loss.  Together: the output's power is the source's to rounding.
//!
//! Off a destination disc, [`Outside::Gutter`] texels take the peaks' value of the texel
//! their mirror image lies in (as the gutter shows the map mirrored across the rim);
//! [`Outside::Black`] rim texels hold their covered fraction, as the sampled path's do.

use super::dest::Dst;
use super::env::EnvMap;
use super::options::Outside;
use crate::base::vec::IDENTITY3 as IDENTITY;
use crate::mappings::mapping::Mapping;
use rayon::prelude::*;

/// Peaks start at this multiple of the map's mean radiance.
pub const PEAK_RATIO: f64 = 8.0;
/// Cells per output texel across a peak texel's extent.
const CELLS_PER_TEXEL: f64 = 4.0;
/// Cells per axis of a peak texel, at least and at most.
const K_MIN: usize = 2;
const K_MAX: usize = 32;

/// The most texels split off as peaks: a 64th of the map, at least 4096.
pub fn max_peaks(texels: usize) -> usize {
    (texels / 64).max(4096)
}

/// A source split into its smooth part and its peaks.
pub(crate) struct Peaks {
    /// The source's texels with every peak texel clipped (`None`: no peaks, the source).
    pub(crate) smooth: Option<Vec<f32>>,
    /// Each peak texel: (x, y, what was clipped per channel).
    texels: Vec<(u32, u32, [f32; 4])>,
    /// The smooth part's power Σ L·dω per channel.
    smooth_power: [f64; 4],
}

impl Peaks {
    pub(crate) fn len(&self) -> usize {
        self.texels.len()
    }
}

/// Splits `src` ([module docs](self)); `None` when the map holds no light to measure.
pub(crate) fn split(src: &EnvMap) -> Option<Peaks> {
    let (w, h, c) = (src.width, src.height, src.channels);
    let rows = src.mapping.texel_rows(w, h);
    let disc = src.mapping.has_outside();
    // Per row (in order, so that the sums do not depend on the threads): Σ L dω, Σ |L| dω and
    // Σ dω over the texels the sampled path reads (of a disc, those whose centre is on it).
    let per_row: Vec<([f64; 4], [f64; 4], f64)> = (0..h)
        .into_par_iter()
        .with_min_len(8)
        .map_init(Vec::new, |om, y| {
            rows.solid_angles(y, om);
            let row = &src.data[y * w * c..(y + 1) * w * c];
            let (mut s, mut a, mut t) = ([0f64; 4], [0f64; 4], 0f64);
            for (x, (px, &o)) in row.chunks_exact(c).zip(om.iter()).enumerate() {
                if o > 0.0 && (!disc || centre_on_map(src, x, y)) {
                    for k in 0..c {
                        s[k] += px[k] as f64 * o;
                        a[k] += (px[k] as f64).abs() * o;
                    }
                    t += o;
                }
            }
            (s, a, t)
        })
        .collect();
    let (mut sums, mut abs, mut total) = ([0f64; 4], [0f64; 4], 0f64);
    for (s, a, t) in &per_row {
        for k in 0..4 {
            sums[k] += s[k];
            abs[k] += a[k];
        }
        total += t;
    }
    if !(total > 0.0) {
        return None;
    }
    // Only light channels whose values are radiance are kept: positive power, and negative
    // values (a lossy codec's small undershoots) that weigh less than a fifth of it.  On
    // signed data a power is no measure of anything.
    let lc = super::energy::light_channels(c);
    let light: [bool; 4] = std::array::from_fn(|k| {
        // Σ L⁻ dω = (Σ |L| dω − Σ L dω) / 2.
        k < lc && sums[k] > 0.0 && (abs[k] - sums[k]) / 2.0 <= 0.2 * sums[k]
    });
    let tau: [f64; 4] = std::array::from_fn(|k| {
        if light[k] {
            PEAK_RATIO * sums[k] / total
        } else {
            f64::INFINITY
        }
    });
    // The power the sampled path sees: what it reads, spread over the whole sphere.
    let seen = 4.0 * std::f64::consts::PI / total;
    let mut smooth_power: [f64; 4] =
        std::array::from_fn(|k| if light[k] { sums[k] * seen } else { f64::NAN });
    // Each candidate texel with its ratio to the threshold (the largest over its channels).
    let ratio = |px: &[f32]| {
        (0..c)
            .filter(|&k| light[k])
            .map(|k| px[k] as f64 / tau[k])
            .fold(0f64, f64::max)
    };
    let mut cand: Vec<(u32, f64)> = (0..h)
        .into_par_iter()
        .with_min_len(8)
        .map_init(Vec::new, |om, y| {
            rows.solid_angles(y, om);
            let row = &src.data[y * w * c..(y + 1) * w * c];
            let mut found = Vec::new();
            for (x, (px, &o)) in row.chunks_exact(c).zip(om.iter()).enumerate() {
                let r = ratio(px);
                if r > 1.0 && o > 0.0 && (!disc || centre_on_map(src, x, y)) {
                    found.push(((y * w + x) as u32, r));
                }
            }
            found
        })
        .flatten()
        .collect();
    if cand.is_empty() {
        return Some(Peaks {
            smooth: None,
            texels: Vec::new(),
            smooth_power,
        });
    }
    // Too many: raise the threshold to the cap's ratio.
    let cap = max_peaks(w * h);
    let mut factor = 1.0;
    if cand.len() > cap {
        cand.select_nth_unstable_by(cap, |a, b| b.1.total_cmp(&a.1));
        factor = cand[cap].1;
        cand.truncate(cap);
        cand.retain(|&(_, r)| r > factor);
    }
    let limit: [f32; 4] = std::array::from_fn(|k| {
        if tau[k] > 0.0 {
            (tau[k] * factor) as f32
        } else {
            f32::INFINITY
        }
    });
    let mut smooth = src.data.to_vec();
    let texels = cand
        .iter()
        .map(|&(i, _)| {
            let i = i as usize;
            let (x, y) = (i % w, i / w);
            let om = src.mapping.texel_solid_angle(x, y, w, h);
            let mut excess = [0f32; 4];
            for k in 0..c {
                let v = &mut smooth[i * c + k];
                if *v > limit[k] {
                    excess[k] = *v - limit[k];
                    *v = limit[k];
                    smooth_power[k] -= excess[k] as f64 * om * seen;
                }
            }
            (x as u32, y as u32, excess)
        })
        .collect();
    Some(Peaks {
        smooth: Some(smooth),
        texels,
        smooth_power,
    })
}

/// Whether texel (x, y)'s centre is on the map (the sampled path reads no other of a disc).
fn centre_on_map(src: &EnvMap, x: usize, y: usize) -> bool {
    let uv = [
        (x as f64 + 0.5) / src.width as f64,
        (y as f64 + 0.5) / src.height as f64,
    ];
    src.mapping.uv_to_dir(uv).is_some()
}

/// The sampled part's total, normalized: each channel of `out` (the smooth part converted)
/// scaled so that its power is the smooth source's, where the two are within a factor of 2
/// (a sampled filter is off by a fraction of a percent; more means a map this rule does not
/// describe, left alone).  Not for [`Outside::Black`] discs, whose rim texels hold their
/// covered fraction by design.
pub(crate) fn normalize<const C: usize>(
    peaks: &Peaks,
    dst: Mapping,
    (w, h): (usize, usize),
    outside: Outside,
    out: &mut [f32],
) {
    if outside == Outside::Black && dst.has_outside() {
        return;
    }
    let rows = dst.texel_rows(w, h);
    // Per row, in order (the sum does not depend on the threads).
    let per_row: Vec<[f64; C]> = out
        .par_chunks(w * C)
        .enumerate()
        .with_min_len(8)
        .map_init(Vec::new, |om, (y, row)| {
            rows.solid_angles(y, om);
            let mut p = [0f64; C];
            for (px, &o) in row.chunks_exact(C).zip(om.iter()) {
                for k in 0..C {
                    p[k] += px[k] as f64 * o;
                }
            }
            p
        })
        .collect();
    let mut power = [0f64; C];
    for p in &per_row {
        for k in 0..C {
            power[k] += p[k];
        }
    }
    let gain: [f32; C] = std::array::from_fn(|k| {
        // (NaN for a channel that is no radiance: left alone.)
        let g = peaks.smooth_power[k] / power[k];
        if (0.5..=2.0).contains(&g) {
            g as f32
        } else {
            1.0
        }
    });
    if gain.iter().all(|&g| g == 1.0) {
        return;
    }
    out.par_chunks_mut(C).with_min_len(4096).for_each(|px| {
        for k in 0..C {
            px[k] *= gain[k];
        }
    });
}

/// Adds the peaks of `src` (split by [`split`]) to `out`, a `w`×`h` canvas of `dst` with `C`
/// channels that holds the smooth part's conversion; `rotation` takes the destination's
/// directions to the source's frame.
pub(crate) fn splat<const C: usize>(
    peaks: &Peaks,
    src: &EnvMap,
    dst: Mapping,
    (w, h): (usize, usize),
    rotation: &[[f64; 3]; 3],
    outside: Outside,
    out: &mut [f32],
) {
    let (sw, sh) = (src.width, src.height);
    let (wf, hf) = (w as f64, h as f64);
    // Source direction → destination canvas pixel position (NaN where it has none).
    let back: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| rotation[j][i]));
    let to_dst = |d: [f64; 3]| {
        let uv = dst.dir_to_uv(crate::frame::conventions::mat3_mul(&back, d));
        [uv[0] * wf, uv[1] * hf]
    };
    let src_dir = |u: f64, v: f64| src.mapping.uv_to_dir([u / sw as f64, v / sh as f64]);
    let index = |p: [f64; 2]| {
        // A direction with no single point (a sphere map's straight-ahead direction) goes to
        // the rim's texel at s = 1.
        let (px, py) = if p[0].is_finite() && p[1].is_finite() {
            (p[0], p[1])
        } else {
            (wf - 0.5, 0.5 * hf)
        };
        let x = (px.floor().max(0.0) as usize).min(w - 1);
        let y = (py.floor().max(0.0) as usize).min(h - 1);
        y * w + x
    };
    // A cell's light goes to the 2×2 output texels round its point with bilinear weights
    // (so its position, not only its texel, is kept: the map's first moments, and with them
    // its SH9 irradiance, stay the source's at coarse sizes); a lat-long's columns wrap, and
    // a tap off the canvas, or across a cube face's edge, is taken by the texel inside.
    let cube_face = matches!(dst, Mapping::Cube(_)).then_some(w);
    let wraps = matches!(dst, Mapping::LatLong(_));
    let taps = |p: [f64; 2], put: &mut dyn FnMut(usize, f64)| {
        if !(p[0].is_finite() && p[1].is_finite()) {
            put(index(p), 1.0);
            return;
        }
        let (fx, fy) = (p[0] - 0.5, p[1] - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (ax, ay) = (fx - x0, fy - y0);
        // The rows the cell's own texel may share: its cube face, else the canvas.
        let own_y = (p[1].floor().max(0.0) as usize).min(h - 1);
        let (ylo, yhi) = match cube_face {
            Some(f) => (own_y / f * f, own_y / f * f + f - 1),
            None => (0, h - 1),
        };
        for (dy, wy) in [(0.0, 1.0 - ay), (1.0, ay)] {
            for (dx, wx) in [(0.0, 1.0 - ax), (1.0, ax)] {
                let b = wx * wy;
                if b <= 0.0 {
                    continue;
                }
                let (xi, yi) = (x0 + dx, y0 + dy);
                let x = if wraps {
                    xi.rem_euclid(wf) as usize
                } else {
                    (xi.max(0.0) as usize).min(w - 1)
                };
                let y = ((yi.max(0.0) as usize).max(ylo)).min(yhi);
                put(y * w + x.min(w - 1), b);
            }
        }
    };
    // Every peak texel's light, as (output texel, light per channel), merged per texel.
    let mut given: Vec<(usize, [f64; C])> = peaks
        .texels
        .par_iter()
        .map_init(
            Vec::new,
            |cells: &mut Vec<(usize, f64)>, &(x, y, excess)| {
                let mut all: Vec<(usize, [f64; C])> = Vec::new();
                let (x, y) = (x as f64, y as f64);
                let omega = src
                    .mapping
                    .texel_solid_angle(x as usize, y as usize, sw, sh);
                if !(omega > 0.0) {
                    return all;
                }
                // The texel's extent on the output canvas, from its centre and edge midpoints.
                let k = match src_dir(x + 0.5, y + 0.5) {
                    Some(dc) => {
                        let pc = to_dst(dc);
                        let span = [(0.0, 0.5), (1.0, 0.5), (0.5, 0.0), (0.5, 1.0)]
                            .iter()
                            .filter_map(|&(ox, oy)| src_dir(x + ox, y + oy))
                            .map(|d| {
                                let p = to_dst(d);
                                2.0 * (p[0] - pc[0]).hypot(p[1] - pc[1])
                            })
                            .fold(
                                0f64,
                                |a, b| if b.is_nan() { f64::INFINITY } else { a.max(b) },
                            );
                        (CELLS_PER_TEXEL * span)
                            .ceil()
                            .clamp(K_MIN as f64, K_MAX as f64) as usize
                    }
                    None => K_MAX,
                };
                cells.clear();
                let mut wsum = 0.0;
                for uv in super::energy::texel_points(x as usize, y as usize, (sw, sh), k) {
                    let Some(d) = src.mapping.uv_to_dir(uv) else {
                        continue;
                    };
                    let wt = src.mapping.density(uv);
                    wsum += wt;
                    taps(to_dst(d), &mut |j, b| cells.push((j, wt * b)));
                }
                if !(wsum > 0.0) {
                    return all;
                }
                cells.sort_unstable_by_key(|c| c.0);
                let mut i = 0;
                while i < cells.len() {
                    let j0 = cells[i].0;
                    let mut wt = 0.0;
                    while i < cells.len() && cells[i].0 == j0 {
                        wt += cells[i].1;
                        i += 1;
                    }
                    let share = omega * wt / wsum;
                    all.push((j0, std::array::from_fn(|k| excess[k] as f64 * share)));
                }
                all
            },
        )
        .flatten()
        .collect();
    // (Stable: equal texels keep the peaks' order, so the sums do not depend on the threads.)
    given.sort_by_key(|g| g.0);
    let mut merged: Vec<(usize, [f64; C])> = Vec::with_capacity(given.len());
    for (j, p) in given {
        match merged.last_mut() {
            Some((lj, lp)) if *lj == j => (0..C).for_each(|k| lp[k] += p[k]),
            _ => merged.push((j, p)),
        }
    }
    // Light given to a texel off the map (a rounding at a disc's rim) goes to its on-map
    // neighbour nearest the disc's centre.
    let omega_of = |j: usize| dst.texel_solid_angle(j % w, j / w, w, h);
    let mut added: Vec<(usize, [f32; C])> = Vec::with_capacity(merged.len());
    for (j, p) in merged {
        let (j, om) = on_map(dst, j, w, h, omega_of);
        if !(om > 0.0) {
            continue;
        }
        let scale = if outside == Outside::Black && dst.has_outside() {
            covered(dst, j % w, j / w, w, h) / om
        } else {
            1.0 / om
        };
        let v: [f32; C] = std::array::from_fn(|k| (p[k] * scale) as f32);
        for k in 0..C {
            out[j * C + k] += v[k];
        }
        added.push((j, v));
    }
    if outside == Outside::Gutter && dst.has_outside() && !added.is_empty() {
        gutter::<C>(dst, w, h, &added, out);
    }
}

/// Texel `j`, or where it is off the map, the on-map texel among its 5×5 neighbours nearest
/// the canvas's centre line of its disc; with that texel's solid angle.
fn on_map(
    dst: Mapping,
    j: usize,
    w: usize,
    h: usize,
    omega_of: impl Fn(usize) -> f64,
) -> (usize, f64) {
    let om = omega_of(j);
    if om > 0.0 {
        return (j, om);
    }
    let (x, y) = ((j % w) as i64, (j / w) as i64);
    // The disc's centre: the canvas's, or for a paraboloid the centre of x's half.
    let cx = match dst {
        Mapping::Paraboloid if 2 * x >= w as i64 => 0.75 * w as f64,
        Mapping::Paraboloid => 0.25 * w as f64,
        _ => 0.5 * w as f64,
    };
    let cy = 0.5 * h as f64;
    let mut best: Option<(f64, usize, f64)> = None;
    for dy in -2..=2i64 {
        for dx in -2..=2i64 {
            let (nx, ny) = (x + dx, y + dy);
            if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                continue;
            }
            let n = ny as usize * w + nx as usize;
            let o = omega_of(n);
            if o > 0.0 {
                let d = (nx as f64 + 0.5 - cx).hypot(ny as f64 + 0.5 - cy);
                if best.is_none_or(|b| d < b.0) {
                    best = Some((d, n, o));
                }
            }
        }
    }
    best.map_or((j, 0.0), |(_, n, o)| (n, o))
}

/// The fraction of texel (x, y)'s weight that lies on the map, as the sampled path weighs it
/// with [`Outside::Black`] (the mapping's density on an 8×8 grid).
fn covered(dst: Mapping, x: usize, y: usize, w: usize, h: usize) -> f64 {
    let (mut on, mut all) = (0.0, 0.0);
    for uv in super::energy::texel_points(x, y, (w, h), 8) {
        let wt = match dst {
            Mapping::Sphere(_) | Mapping::Octahedral => 1.0,
            m => m.density(uv),
        };
        all += wt;
        if dst.uv_to_dir(uv).is_some() {
            on += wt;
        }
    }
    if all > 0.0 {
        on / all
    } else {
        1.0
    }
}

/// Gutter texels (wholly off the disc) take the light `added` gave the texel their mirror
/// image lies in.
fn gutter<const C: usize>(
    dst: Mapping,
    w: usize,
    h: usize,
    added: &[(usize, [f32; C])],
    out: &mut [f32],
) {
    let mirror = Dst::<f64>::new(dst, w, h, &IDENTITY, Outside::Gutter);
    let mut sorted = added.to_vec();
    sorted.sort_unstable_by_key(|a| a.0);
    let find_sorted = |j: usize| {
        sorted
            .binary_search_by_key(&j, |a| a.0)
            .ok()
            .map(|i| sorted[i].1)
    };
    out.par_chunks_mut(w * C).enumerate().for_each(|(y, row)| {
        for x in 0..w {
            if !wholly_off(dst, x, y, w, h) {
                continue;
            }
            let (d, on) = mirror.dir(x as f64 + 0.5, y as f64 + 0.5);
            if on {
                continue;
            }
            let uv = dst.dir_to_uv(d);
            if !(uv[0].is_finite() && uv[1].is_finite()) {
                continue;
            }
            let mx = ((uv[0] * w as f64).floor().max(0.0) as usize).min(w - 1);
            let my = ((uv[1] * h as f64).floor().max(0.0) as usize).min(h - 1);
            if let Some(v) = find_sorted(my * w + mx) {
                for k in 0..C {
                    row[x * C + k] += v[k];
                }
            }
        }
    });
}

/// Whether texel (x, y) of a `w`×`h` canvas of a disc mapping lies wholly off the map: its
/// point nearest its disc's centre is off it.
pub(crate) fn wholly_off(dst: Mapping, x: usize, y: usize, w: usize, h: usize) -> bool {
    let (wf, hf) = (w as f64, h as f64);
    let cx = match dst {
        Mapping::Paraboloid if 2 * x >= w => 0.75 * wf,
        Mapping::Paraboloid => 0.25 * wf,
        _ => 0.5 * wf,
    };
    let cy = 0.5 * hf;
    let near = |c: f64, lo: f64| c.clamp(lo, lo + 1.0);
    let (px, py) = (near(cx, x as f64), near(cy, y as f64));
    // A hair toward the centre: a texel that only touches the rim counts as off.
    let (dx, dy) = (cx - px, cy - py);
    let l = dx.hypot(dy).max(1e-300);
    let e = 1e-9;
    dst.uv_to_dir([(px + dx / l * e) / wf, (py + dy / l * e) / hf])
        .is_none()
}
