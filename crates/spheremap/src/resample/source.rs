//! The source side of a conversion: a canvas, its wrap rules and bilinear lookups.

use super::env::EnvMap;
use super::options::Taps;
use super::pyramid::{Level, NO_ROW};
use crate::base::real::Real;
use crate::frame::conventions::mat3_mul;
use crate::mappings::cube;
use crate::mappings::mapping::Mapping;

/// The source side: canvas, wrap rules, bilinear lookups.
pub(super) struct Src<'a, T: Real> {
    pub(super) m: Mapping,
    pub(super) w: usize,
    pub(super) h: usize,
    pub(super) data: &'a [f32],
    pub(super) wf: T,
    pub(super) hf: T,
    /// Cube face size (the canvas width) — 0 for other mappings.
    pub(super) face: usize,
    /// Disc mappings: a sample this close to the centre (in pixels, squared) has all four taps
    /// inside the disc.
    pub(super) safe_r2: T,
    /// Where each canvas row lies in `data` (`pyramid::NO_ROW`: not held), or empty when all
    /// are held in order (the source itself; a pyramid level may hold only the rows some
    /// lookup needs).
    pub(super) rowmap: &'a [u32],
    /// Bicubic taps ([`Taps::Bicubic`]; the source itself only).
    pub(super) cubic: bool,
}

/// Catmull–Rom weights of the texels at offsets −1, 0, 1, 2 from a sample `t` ∈ [0, 1) past
/// texel 0.
#[inline(always)]
fn catmull_rom<T: Real>(t: T) -> [T; 4] {
    let h = T::HALF;
    let (t2, t3) = (t * t, t * t * t);
    let two = T::TWO;
    let three = T::from_f64(3.0);
    [
        h * (two * t2 - t3 - t),
        h * (three * t3 - T::from_f64(5.0) * t2 + two),
        h * (T::from_f64(4.0) * t2 - three * t3 + t),
        h * (t3 - t2),
    ]
}

impl<'a, T: Real> Src<'a, T> {
    pub(super) fn new(e: &EnvMap<'a>) -> Self {
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
            rowmap: &[],
            cubic: false,
        }
    }

    /// The same source read with `taps`.
    pub(super) fn with_taps(mut self, taps: Taps) -> Self {
        self.cubic = taps == Taps::Bicubic;
        self
    }

    /// The same map at a prefiltered level (positions scale by `level.scale()`).
    pub(super) fn level<'b>(&self, lv: &'b Level) -> Src<'b, T> {
        let n = lv.h as f64;
        let safe = (0.5 * n - 1.5).max(0.0);
        Src {
            m: self.m,
            w: lv.w,
            h: lv.h,
            data: &lv.data,
            wf: T::from_f64(lv.w as f64),
            hf: T::from_f64(lv.h as f64),
            face: if self.face > 0 { lv.w } else { 0 },
            safe_r2: T::from_f64(safe * safe),
            rowmap: &lv.rowmap,
            cubic: false,
        }
    }

    /// A canvas texel index (`y·w + x`) as an index into the rows held.  A row not held is
    /// replaced by the nearest held one: a level's rows are chosen with a margin, so this is
    /// a safety net, not a rule.
    #[inline(always)]
    fn held(&self, i: usize) -> usize {
        if self.rowmap.is_empty() {
            return i;
        }
        let (y, x) = (i / self.w, i % self.w);
        let r = self.rowmap[y];
        let r = if r != NO_ROW {
            r
        } else {
            let near = (1..self.h).find_map(|d| {
                [y.checked_sub(d), Some(y + d)]
                    .into_iter()
                    .flatten()
                    .find_map(|yy| self.rowmap.get(yy).copied().filter(|&r| r != NO_ROW))
            });
            near.unwrap_or(0)
        };
        r as usize * self.w + x
    }

    /// Where canvas row `y0` lies in `data` when rows `y0` and `y0 + 1` are both held (and
    /// so consecutive there).
    #[inline(always)]
    pub(super) fn held_pair(&self, y0: usize) -> Option<usize> {
        if self.rowmap.is_empty() {
            return Some(y0);
        }
        let r = self.rowmap[y0];
        (r != NO_ROW && self.rowmap[y0 + 1] == r + 1).then_some(r as usize)
    }

    /// Continuous source pixel position of a direction (NaN-free: the sphere map's single
    /// singular direction is placed on its rim).
    #[inline(always)]
    pub(super) fn position(&self, d: [T; 3]) -> [T; 2] {
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

    /// Bicubic lookup ([`Taps::Bicubic`]); false where a tap of the 4×4 is off the map (the
    /// caller then reads bilinearly).
    fn lookup_cubic<const C: usize>(&self, p: [T; 2], weight: T, acc: &mut [T; C]) -> bool {
        let px = p[0] - T::HALF;
        let py = p[1] - T::HALF;
        let (fx0, fy0) = (px.floor(), py.floor());
        let x0 = fx0.to_f64() as isize;
        let y0 = fy0.to_f64() as isize;
        let (wx, wy) = (catmull_rom(px - fx0), catmull_rom(py - fy0));
        let mut idx = [0usize; 16];
        for j in 0..4 {
            for i in 0..4 {
                match self.tap(x0 - 1 + i as isize, y0 - 1 + j as isize, p) {
                    Some(t) => idx[j * 4 + i] = self.held(t),
                    None => return false,
                }
            }
        }
        let at = |k: usize, c: usize| T::from_f64(self.data[idx[k] * C + c] as f64);
        for c in 0..C {
            let mut v = T::ZERO;
            for j in 0..4 {
                let mut row = T::ZERO;
                for i in 0..4 {
                    row = row + wx[i] * at(j * 4 + i, c);
                }
                v = v + wy[j] * row;
            }
            // Clamped to the 2×2 nearest texels' range (taps 5, 6, 9, 10 of the 4×4).
            let near = [at(5, c), at(6, c), at(9, c), at(10, c)];
            let lo = near.iter().copied().fold(near[0], |a, b| a.min(b));
            let hi = near.iter().copied().fold(near[0], |a, b| a.max(b));
            acc[c] = acc[c] + weight * v.max(lo).min(hi);
        }
        true
    }

    /// Lookup at continuous pixel position `p` (bilinear, or bicubic for [`Taps::Bicubic`]),
    /// accumulating `weight ×` the value.
    #[inline(always)]
    pub(super) fn lookup<const C: usize>(&self, p: [T; 2], weight: T, acc: &mut [T; C]) {
        if self.cubic && self.lookup_cubic(p, weight, acc) {
            return;
        }
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
            // `fast` checked that the pair is held.
            let r0 = self.held_pair(y0 as usize).unwrap_or(0);
            let i00 = (r0 * self.w + x0 as usize) * C;
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
                idx[j] = self.held(i);
                wsum = wsum + wts[j];
            }
        }
        if !(wsum > T::ZERO) {
            // All taps off the map (a sample in the last half texel of a tiny disc): nearest.
            let i = self.held(self.nearest(p));
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
    pub(super) fn fast(&self, x0: isize, y0: isize, p: [T; 2]) -> bool {
        if x0 < 0 || y0 < 0 || x0 as usize + 1 >= self.w || y0 as usize + 1 >= self.h {
            return false;
        }
        if self.held_pair(y0 as usize).is_none() {
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
    pub(super) fn tap(&self, x: isize, y: isize, p: [T; 2]) -> Option<usize> {
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
    pub(super) fn nearest(&self, p: [T; 2]) -> usize {
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

impl<T: Real> Src<'_, T> {
    /// How many source texels lie between two source positions (the directions `da`, `db` are
    /// used where pixel distance means nothing: across a cube seam).
    #[inline(always)]
    pub(super) fn span(&self, a: [T; 2], b: [T; 2], da: [T; 3], db: [T; 3]) -> f64 {
        let (mut dx, dy) = ((b[0] - a[0]).to_f64().abs(), (b[1] - a[1]).to_f64().abs());
        match self.m {
            Mapping::LatLong(_) => {
                // At a pole a direction has no azimuth: its column is rounding noise (sin π
                // is 1e-16 in f64, −9e-8 in f32), so a footprint edge there (a lat-long
                // texel's top or bottom edge) measures rows only — the same in both paths.
                // "There": within 1e-6 rad, i.e. that close to row 0 or row h.
                let (h, eps) = (
                    self.hf.to_f64(),
                    self.hf.to_f64() * (1e-6 / std::f64::consts::PI),
                );
                let at_pole = |p: [T; 2]| {
                    let v = p[1].to_f64();
                    v <= eps || v >= h - eps
                };
                dx = if at_pole(a) || at_pole(b) {
                    0.0
                } else {
                    dx.min(self.w as f64 - dx)
                };
            }
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
        (dx * dx + dy * dy).sqrt()
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
