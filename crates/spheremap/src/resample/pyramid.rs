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
//! lat-long level may hold only a band of rows (`row0 .. row0 + rows`): the rows that the
//! lookups of this conversion need (measured beforehand from the texels' footprints), so
//! that shrinking a large lat-long into a small sphere map does not allocate a third of the
//! input again for the few rim texels that read the coarse levels.

use super::*;

/// One level: a canvas of `w`×`h` of which rows `row0 .. row0 + rows` are held in `data`.
pub(crate) struct Level {
    pub(crate) w: usize,
    pub(crate) h: usize,
    pub(crate) row0: usize,
    pub(crate) rows: usize,
    pub(crate) data: Vec<f32>,
}

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

/// Rows of each level that lookups need: `lo[k]..=hi[k]` for level k + 1 (empty when lo > hi).
pub(super) struct Need {
    lo: Vec<AtomicUsize>,
    hi: Vec<AtomicUsize>,
    /// The level's rows in all (the other mappings: their wrap rules reach any row).
    whole: bool,
    h: usize,
}

impl Need {
    pub(super) fn new(m: Mapping, depth: usize, h: usize) -> Self {
        Need {
            lo: (0..depth).map(|_| AtomicUsize::new(usize::MAX)).collect(),
            hi: (0..depth).map(|_| AtomicUsize::new(0)).collect(),
            whole: !matches!(m, Mapping::LatLong(_)),
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
        if k == 0 || k > self.lo.len() {
            return;
        }
        let hk = (self.h >> k) as f64;
        let s = 1.0 / (1u64 << k) as f64;
        // Two level-k rows of margin: the bilinear taps, and rounding between the estimate and
        // the lookups.
        let a = (y0 * s - 2.0).floor().clamp(0.0, hk - 1.0) as usize;
        let b = (y1 * s + 2.0).ceil().clamp(0.0, hk - 1.0) as usize;
        self.lo[k - 1].fetch_min(a, Ordering::Relaxed);
        self.hi[k - 1].fetch_max(b, Ordering::Relaxed);
    }

    /// The deepest level marked.
    pub(super) fn depth(&self) -> usize {
        (1..=self.lo.len())
            .rev()
            .find(|&k| self.lo[k - 1].load(Ordering::Relaxed) != usize::MAX)
            .unwrap_or(0)
    }

    /// Held rows per level 1..=depth: each level also holds the parents of the next one's.
    fn windows(&self, depth: usize) -> Vec<(usize, usize)> {
        let mut win = vec![(0usize, 0usize); depth];
        let mut below: Option<(usize, usize)> = None;
        for k in (1..=depth).rev() {
            let hk = self.h >> k;
            let own = if self.whole {
                Some((0, hk - 1))
            } else {
                let (a, b) = (
                    self.lo[k - 1].load(Ordering::Relaxed),
                    self.hi[k - 1].load(Ordering::Relaxed),
                );
                (a <= b).then_some((a, b))
            };
            // Level k + 1 rows c..=d are built from level-k rows 2c ..= 2d + 1.
            let parents = below.map(|(c, d)| (2 * c, 2 * d + 1));
            let (a, b) = match (own, parents) {
                (Some((a, b)), Some((c, d))) => (a.min(c), b.max(d)),
                (Some(w), None) | (None, Some(w)) => w,
                (None, None) => (0, 0),
            };
            win[k - 1] = (a.min(hk - 1), b.min(hk - 1));
            below = Some(win[k - 1]);
        }
        win
    }

    /// Bytes the levels up to `depth` would take with these windows.
    pub(super) fn bytes(&self, src: &EnvMap, depth: usize) -> u128 {
        self.windows(depth)
            .iter()
            .enumerate()
            .map(|(i, &(a, b))| ((src.width >> (i + 1)) * (b - a + 1) * src.channels) as u128 * 4)
            .sum()
    }
}

/// Levels 1..=depth of `src`, each holding the rows `need` asks for.
pub(super) fn build(src: &EnvMap, need: &Need, depth: usize) -> Vec<Level> {
    let c = src.channels;
    let mut levels: Vec<Level> = Vec::with_capacity(depth);
    for (i, (a, b)) in need.windows(depth).into_iter().enumerate() {
        let k = i + 1;
        let (w, h) = (src.width >> k, src.height >> k);
        let (pw, ph, prow0, pdata) = match levels.last() {
            Some(l) => (l.w, l.h, l.row0, &l.data[..]),
            None => (src.width, src.height, 0, src.data),
        };
        let rows = b - a + 1;
        let mut data = vec![0.0f32; w * rows * c];
        data.par_chunks_mut(w * c).enumerate().for_each(|(j, out)| {
            let y = a + j;
            // Parent rows 2y and 2y + 1, held from prow0.
            let r0 = &pdata[(2 * y - prow0) * pw * c..][..pw * c];
            let r1 = &pdata[(2 * y + 1 - prow0) * pw * c..][..pw * c];
            halve_row(src.mapping, ph, 2 * y, r0, r1, c, out);
        });
        levels.push(Level {
            w,
            h,
            row0: a,
            rows,
            data,
        });
    }
    levels
}

/// One output row from parent rows `py` and `py + 1` of a canvas `ph` rows high.
fn halve_row(m: Mapping, ph: usize, py: usize, r0: &[f32], r1: &[f32], c: usize, out: &mut [f32]) {
    match m {
        Mapping::LatLong(_) => {
            let wt = |y: usize| ((y as f64 + 0.5) / ph as f64 * std::f64::consts::PI).sin();
            let (w0, w1) = (wt(py), wt(py + 1));
            let (k0, k1) = ((0.5 * w0 / (w0 + w1)) as f32, (0.5 * w1 / (w0 + w1)) as f32);
            for (x, o) in out.chunks_exact_mut(c).enumerate() {
                for (ch, o) in o.iter_mut().enumerate() {
                    let (i, j) = (2 * x * c + ch, (2 * x + 1) * c + ch);
                    *o = k0 * (r0[i] + r0[j]) + k1 * (r1[i] + r1[j]);
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
                    *o = s / cnt;
                }
            }
        }
        Mapping::Cube(_) | Mapping::Octahedral => {
            for (x, o) in out.chunks_exact_mut(c).enumerate() {
                for (ch, o) in o.iter_mut().enumerate() {
                    let (i, j) = (2 * x * c + ch, (2 * x + 1) * c + ch);
                    *o = 0.25 * (r0[i] + r0[j] + r1[i] + r1[j]);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn latlong_levels_hold_only_the_rows_asked_for_and_their_parents() {
        let mp = Mapping::parse("latlong", None).unwrap();
        let img = env(256, 128, |x, y| (x + 1000 * y) as f32);
        let e = EnvMap::new(mp, &img, "t").unwrap();
        let need = Need::new(mp, 3, 128);
        // Level 3 (16 rows): level-0 rows 60..68 → 7.5..8.5, then ± 2 rows: 5..=11.
        need.mark(3, 60.0, 68.0);
        let l = build(&e, &need, 3);
        assert_eq!((l[2].row0, l[2].rows), (5, 7));
        // Level 2 holds their parents 10..=23, level 1 theirs, 20..=47.
        assert_eq!((l[1].row0, l[1].rows), (10, 14));
        assert_eq!((l[0].row0, l[0].rows), (20, 28));
        assert!(need.bytes(&e, 3) < (256 * 128 * 4 / 4) as u128);
        // Values: level 1 row 20 col 0 averages level-0 rows 40, 41, columns 0, 1.
        let sin = |y: f64| ((y + 0.5) / 128.0 * std::f64::consts::PI).sin();
        let (w0, w1) = (sin(40.0), sin(41.0));
        let want = 0.5 + 1000.0 * (40.0 * w0 + 41.0 * w1) / (w0 + w1);
        let v = l[0].data[0] as f64;
        assert!((v - want).abs() < 0.01, "{v} {want}");
    }
}
