//! Prefiltered source levels: the mip pyramid that filtered conversions read where a texel's
//! footprint is wider than its samples can cover.
//!
//! Level k is the source halved k times (each texel the average of its 2×2 children), so a
//! continuous source position p (in level-0 pixels) is p / 2ᵏ at level k.  The averages
//! respect each mapping's meaning:
//!
//! * lat-long: the two child rows are weighted by their sin θ (their solid angles), so a level
//!   near a pole is a solid-angle average, not a flat one;
//! * cube: within each face (faces stay stacked; a face's size halves with the canvas);
//! * sphere, angular, paraboloid: only children whose centres lie inside the disc count, so
//!   whatever the file holds outside it (black, a gutter, a photo's background) never bleeds in;
//! * octahedral: the plain 2×2 average.
//!
//! A level exists while both canvas sides (a cube's face) halve exactly and stay ≥ 2.  A
//! lat-long level may hold only some of its rows: those that the lookups of this conversion
//! need (measured beforehand from the texels' footprints), and the parents of the next
//! level's.  The rows held need not be contiguous — a sphere map's rim and the texels that
//! see the two poles ask for three separate bands — so shrinking a large lat-long into a
//! smaller sphere map does not allocate a third of the input again for the few texels that
//! read the coarse levels.  `Level::rowmap` says where each held canvas row lies in `data`.

use super::env::EnvMap;
use crate::mappings::mapping::Mapping;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// One level: a canvas of `w`×`h` of which the rows with `rowmap[y] != NO_ROW` are held, row
/// y at `data[rowmap[y]·w·C ..]`, in canvas order.
pub(crate) struct Level {
    pub(crate) w: usize,
    pub(crate) h: usize,
    pub(crate) rowmap: Vec<u32>,
    pub(crate) data: Vec<f32>,
}

/// `Level::rowmap` of a row that is not held.
pub(crate) const NO_ROW: u32 = u32::MAX;

/// How many times a `w`×`h` canvas of `m` halves exactly.
pub(super) fn max_depth(m: Mapping, w: usize, h: usize) -> usize {
    let (mut w, mut h) = (w, h);
    let mut k = 0;
    // A cube halves with its face (the canvas width); the others with both sides.
    while w % 2 == 0 && h % 2 == 0 && w >= 4 && h >= 4 && k < 30 {
        if matches!(m, Mapping::Cube(_)) && (w / 2) < 2 {
            break;
        }
        w /= 2;
        h /= 2;
        k += 1;
    }
    k
}

/// Rows of each level that lookups need: `rows[k − 1][y]` for level k.
pub(super) struct Need {
    rows: Vec<Vec<AtomicBool>>,
    /// Level k is read at all.
    used: Vec<AtomicBool>,
    /// The level's rows in all (the other mappings: their wrap rules reach any row).
    whole: bool,
    h: usize,
}

impl Need {
    pub(super) fn new(m: Mapping, depth: usize, h: usize) -> Self {
        let whole = !matches!(m, Mapping::LatLong(_));
        Need {
            rows: (1..=depth)
                .map(|k| {
                    let n = if whole { 0 } else { h >> k };
                    (0..n).map(|_| AtomicBool::new(false)).collect()
                })
                .collect(),
            used: (0..depth).map(|_| AtomicBool::new(false)).collect(),
            whole,
            h,
        }
    }

    /// Every row of every level 1..=depth (no footprint pre-pass).
    pub(super) fn everything(m: Mapping, depth: usize, h: usize) -> Self {
        let need = Need::new(m, depth, h);
        for k in 1..=depth {
            need.mark(k, 0.0, h as f64);
        }
        need
    }

    /// Lookups at level `k` ≥ 1 touch level-0 rows `y0 ..= y1` (continuous, any margin added
    /// here).
    pub(super) fn mark(&self, k: usize, y0: f64, y1: f64) {
        if k == 0 || k > self.used.len() {
            return;
        }
        self.used[k - 1].store(true, Ordering::Relaxed);
        if self.whole {
            return;
        }
        let hk = (self.h >> k) as f64;
        let s = 1.0 / (1u64 << k) as f64;
        // Two level-k rows of margin: the bilinear taps, and rounding between the estimate and
        // the lookups.
        let a = (y0 * s - 2.0).floor().clamp(0.0, hk - 1.0) as usize;
        let b = (y1 * s + 2.0).ceil().clamp(0.0, hk - 1.0) as usize;
        for r in &self.rows[k - 1][a..=b.max(a)] {
            // Read first: most rows are marked many times, and a store would bounce the
            // cache line between the threads.
            if !r.load(Ordering::Relaxed) {
                r.store(true, Ordering::Relaxed);
            }
        }
    }

    /// The deepest level marked.
    pub(super) fn depth(&self) -> usize {
        (1..=self.used.len())
            .rev()
            .find(|&k| self.used[k - 1].load(Ordering::Relaxed))
            .unwrap_or(0)
    }

    /// Held rows per level 1..=depth: its own, and the parents of the next level's.
    fn held(&self, depth: usize) -> Vec<Vec<bool>> {
        let mut held: Vec<Vec<bool>> = vec![vec![]; depth];
        for k in (1..=depth).rev() {
            let hk = self.h >> k;
            let mut own: Vec<bool> = if self.whole {
                vec![true; hk]
            } else {
                self.rows[k - 1]
                    .iter()
                    .map(|r| r.load(Ordering::Relaxed))
                    .collect()
            };
            if k < depth {
                // Level k + 1 row y is built from level-k rows 2y and 2y + 1.
                for (y, &h) in held[k].iter().enumerate() {
                    if h {
                        own[2 * y] = true;
                        own[2 * y + 1] = true;
                    }
                }
            }
            held[k - 1] = own;
        }
        held
    }

    /// Bytes the levels up to `depth` would take.
    pub(super) fn bytes(&self, src: &EnvMap, depth: usize) -> u128 {
        self.held(depth)
            .iter()
            .enumerate()
            .map(|(i, rows)| {
                let n = rows.iter().filter(|&&h| h).count();
                ((src.width >> (i + 1)) * n * src.channels) as u128 * 4
            })
            .sum()
    }
}

/// Levels 1..=depth of `src`, each holding the rows `need` asks for.
pub(super) fn build(src: &EnvMap, need: &Need, depth: usize) -> Vec<Level> {
    let c = src.channels;
    let mut levels: Vec<Level> = Vec::with_capacity(depth);
    for (i, held) in need.held(depth).into_iter().enumerate() {
        let k = i + 1;
        let (w, h) = (src.width >> k, src.height >> k);
        let ys: Vec<usize> = (0..h).filter(|&y| held[y]).collect();
        let mut rowmap = vec![NO_ROW; h];
        for (j, &y) in ys.iter().enumerate() {
            rowmap[y] = j as u32;
        }
        // The parent canvas: the source (all rows) or the previous level (its rowmap).
        let (pw, ph, pdata, pmap) = match levels.last() {
            Some(l) => (l.w, l.h, &l.data[..], Some(&l.rowmap[..])),
            None => (src.width, src.height, src.data, None),
        };
        let parent = |y: usize| {
            let r = pmap.map_or(y, |m| m[y] as usize);
            &pdata[r * pw * c..][..pw * c]
        };
        // Not zeroed first: every value is written below (zeroing cost 1 % of a J4 job).
        let n = w * ys.len() * c;
        let mut data: Vec<f32> = Vec::with_capacity(n);
        data.spare_capacity_mut()[..n]
            .par_chunks_mut(w * c)
            .zip(&ys)
            .for_each(|(out, &y)| {
                halve_row(
                    src.mapping,
                    ph,
                    2 * y,
                    parent(2 * y),
                    parent(2 * y + 1),
                    c,
                    out,
                );
            });
        // SAFETY: `halve_row` wrote each of the n values (every texel's c channels of every
        // row: the chunks cover the n exactly, w·c each).
        unsafe { data.set_len(n) };
        levels.push(Level { w, h, rowmap, data });
    }
    levels
}

/// A lat-long row of `C` channels halved: pairs of texels of rows `r0`, `r1` weighted
/// `k0`, `k1` (each pair's two texels alike).
fn halve_ll<const C: usize>(r0: &[f32], r1: &[f32], k0: f32, k1: f32, out: &mut [Uninit]) {
    let pairs = r0.chunks_exact(2 * C).zip(r1.chunks_exact(2 * C));
    for (o, (a, b)) in out.chunks_exact_mut(C).zip(pairs) {
        for ch in 0..C {
            o[ch].write(k0 * (a[ch] + a[C + ch]) + k1 * (b[ch] + b[C + ch]));
        }
    }
}

/// A level's value before it is written.
type Uninit = std::mem::MaybeUninit<f32>;

/// One output row from parent rows `py` and `py + 1` of a canvas `ph` rows high, writing
/// every value of `out`.
fn halve_row(
    m: Mapping,
    ph: usize,
    py: usize,
    r0: &[f32],
    r1: &[f32],
    c: usize,
    out: &mut [Uninit],
) {
    match m {
        Mapping::LatLong(_) => {
            let wt = |y: usize| ((y as f64 + 0.5) / ph as f64 * std::f64::consts::PI).sin();
            let (w0, w1) = (wt(py), wt(py + 1));
            let (k0, k1) = ((0.5 * w0 / (w0 + w1)) as f32, (0.5 * w1 / (w0 + w1)) as f32);
            // With the channel count known to the compiler, the loop vectorizes.
            match c {
                1 => halve_ll::<1>(r0, r1, k0, k1, out),
                2 => halve_ll::<2>(r0, r1, k0, k1, out),
                3 => halve_ll::<3>(r0, r1, k0, k1, out),
                4 => halve_ll::<4>(r0, r1, k0, k1, out),
                _ => {
                    for (x, o) in out.chunks_exact_mut(c).enumerate() {
                        for (ch, o) in o.iter_mut().enumerate() {
                            let (i, j) = (2 * x * c + ch, (2 * x + 1) * c + ch);
                            o.write(k0 * (r0[i] + r0[j]) + k1 * (r1[i] + r1[j]));
                        }
                    }
                }
            }
        }
        Mapping::Sphere(_) | Mapping::Angular | Mapping::Paraboloid => {
            // The disc of the half a texel belongs to: N = ph, centred on its half.
            let n = ph as f64;
            let inside = |x: usize, y: usize| {
                let cx = if x >= ph { 1.5 * n } else { 0.5 * n };
                let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - 0.5 * n);
                dx * dx + dy * dy <= 0.25 * n * n
            };
            for (x, o) in out.chunks_exact_mut(c).enumerate() {
                let kids = [
                    (r0, 2 * x, py),
                    (r0, 2 * x + 1, py),
                    (r1, 2 * x, py + 1),
                    (r1, 2 * x + 1, py + 1),
                ];
                let ins = kids.map(|(_, kx, ky)| inside(kx, ky));
                let all = !ins.iter().any(|&b| b);
                let cnt = if all {
                    4.0
                } else {
                    ins.iter().filter(|&&b| b).count() as f32
                };
                for (ch, o) in o.iter_mut().enumerate() {
                    let mut s = 0.0f32;
                    for (j, &(r, kx, _)) in kids.iter().enumerate() {
                        if all || ins[j] {
                            s += r[kx * c + ch];
                        }
                    }
                    o.write(s / cnt);
                }
            }
        }
        Mapping::Cube(_) | Mapping::Octahedral => {
            for (x, o) in out.chunks_exact_mut(c).enumerate() {
                for (ch, o) in o.iter_mut().enumerate() {
                    let (i, j) = (2 * x * c + ch, (2 * x + 1) * c + ch);
                    o.write(0.25 * (r0[i] + r0[j] + r1[i] + r1[j]));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::images::Image;

    fn env(w: usize, h: usize, f: impl Fn(usize, usize) -> f32) -> Image {
        let mut img = Image::new(w, h, 1);
        for y in 0..h {
            for x in 0..w {
                img.data[y * w + x] = f(x, y);
            }
        }
        img
    }

    #[test]
    fn depth_counts_exact_halvings() {
        let ll = Mapping::parse("latlong", None).unwrap();
        let cube = Mapping::parse("cube", None).unwrap();
        assert_eq!(max_depth(ll, 2048, 1024), 9);
        assert_eq!(max_depth(ll, 6000, 3000), 3);
        assert_eq!(max_depth(cube, 512, 3072), 8);
        assert_eq!(max_depth(ll, 3, 2), 0);
    }

    #[test]
    fn constant_stays_constant_and_latlong_weights_by_solid_angle() {
        for m in ["latlong", "cube", "sphere", "paraboloid", "octahedral"] {
            let mp = Mapping::parse(m, None).unwrap();
            let (w, h) = mp.canvas(32);
            let img = env(w, h, |_, _| 2.5);
            let e = EnvMap::new(mp, &img, "t").unwrap();
            let d = max_depth(mp, w, h);
            let need = Need::new(mp, d, h);
            need.mark(d, 0.0, h as f64);
            let levels = build(&e, &need, d);
            for l in &levels {
                for &v in &l.data {
                    assert!((v - 2.5).abs() < 1e-5, "{m}: {v}");
                }
            }
        }
        // Rows 0 and 1 of a 4-row lat-long: sin(π/8) and sin(3π/8).
        let mp = Mapping::parse("latlong", None).unwrap();
        let img = env(8, 4, |_, y| y as f32);
        let e = EnvMap::new(mp, &img, "t").unwrap();
        let need = Need::new(mp, 1, 4);
        need.mark(1, 0.0, 4.0);
        let l = build(&e, &need, 1);
        let (a, b) = (
            (std::f64::consts::PI / 8.0).sin(),
            (3.0 * std::f64::consts::PI / 8.0).sin(),
        );
        assert!((l[0].data[0] as f64 - b / (a + b)).abs() < 1e-6);
    }

    /// The rows level k holds.
    fn held_rows(l: &Level) -> Vec<usize> {
        (0..l.h).filter(|&y| l.rowmap[y] != NO_ROW).collect()
    }

    #[test]
    fn latlong_levels_hold_only_the_rows_asked_for_and_their_parents() {
        let mp = Mapping::parse("latlong", None).unwrap();
        let img = env(256, 128, |x, y| (x + 1000 * y) as f32);
        let e = EnvMap::new(mp, &img, "t").unwrap();
        let need = Need::new(mp, 3, 128);
        // Level 3 (16 rows): level-0 rows 60..68 → 7.5..8.5, then ± 2 rows: 5..=11.
        need.mark(3, 60.0, 68.0);
        assert_eq!(need.depth(), 3);
        let l = build(&e, &need, 3);
        assert_eq!(held_rows(&l[2]), (5..=11).collect::<Vec<_>>());
        // Level 2 holds their parents 10..=23, level 1 theirs, 20..=47.
        assert_eq!(held_rows(&l[1]), (10..=23).collect::<Vec<_>>());
        assert_eq!(held_rows(&l[0]), (20..=47).collect::<Vec<_>>());
        assert_eq!(l[0].data.len(), 28 * 128);
        assert!(need.bytes(&e, 3) < (256 * 128 * 4 / 4) as u128);
        // Values: level 1 row 20 col 0 averages level-0 rows 40, 41, columns 0, 1.
        let sin = |y: f64| ((y + 0.5) / 128.0 * std::f64::consts::PI).sin();
        let (w0, w1) = (sin(40.0), sin(41.0));
        let want = 0.5 + 1000.0 * (40.0 * w0 + 41.0 * w1) / (w0 + w1);
        let v = l[0].data[0] as f64;
        assert!((v - want).abs() < 0.01, "{v} {want}");
    }

    #[test]
    fn separate_bands_stay_separate() {
        // The two poles and the equator (what a sphere map's rim and pole texels ask for):
        // three bands, not one window over the whole height.
        let mp = Mapping::parse("latlong", None).unwrap();
        let img = env(256, 128, |x, y| (x + 1000 * y) as f32);
        let e = EnvMap::new(mp, &img, "t").unwrap();
        let need = Need::new(mp, 1, 128);
        need.mark(1, 0.0, 2.0);
        need.mark(1, 62.0, 66.0);
        need.mark(1, 126.0, 128.0);
        let l = build(&e, &need, 1);
        let want: Vec<usize> = (0..=3).chain(29..=35).chain(61..=63).collect();
        assert_eq!(held_rows(&l[0]), want);
        assert_eq!(l[0].data.len(), want.len() * 128);
        // Each held row holds its own values: row 61 averages level-0 rows 122 and 123.
        let r = l[0].rowmap[61] as usize;
        let sin = |y: f64| ((y + 0.5) / 128.0 * std::f64::consts::PI).sin();
        let (w0, w1) = (sin(122.0), sin(123.0));
        let want = 0.5 + 1000.0 * (122.0 * w0 + 123.0 * w1) / (w0 + w1);
        let v = l[0].data[r * 128] as f64;
        assert!((v - want).abs() < 0.05, "{v} {want}");
        // Other mappings hold every row.
        let sp = Mapping::parse("sphere", None).unwrap();
        let img = env(64, 64, |_, _| 1.0);
        let e = EnvMap::new(sp, &img, "t").unwrap();
        let need = Need::new(sp, 2, 64);
        need.mark(2, 10.0, 12.0);
        let l = build(&e, &need, 2);
        assert_eq!(held_rows(&l[0]).len(), 32);
        assert_eq!(held_rows(&l[1]).len(), 16);
    }
}
