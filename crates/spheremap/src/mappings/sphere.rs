//! The sphere mapping: directions ↔ (s,t), the reflection it is built on, and the exact solid
//! angle of every texel.  Frames and orientation are those of [`crate::frame::conventions`].
//!
//! ## Derivation (forward)
//!
//! The map is an orthographic photo of a unit mirror ball.  A ball normal `n` reflects the view
//! ray `(0,0,−1)` into `r = (0,0,−1) + 2 n_z n`, so `n ∝ r + (0,0,1)`: the normal is the half
//! vector between `r` and the direction back to the viewer.  Its x and y are the disc
//! coordinates, `(2s − 1, 2t − 1) = (r_x, r_y) / |r + (0,0,1)|`, which is GL's
//! `m = 2 √(r_x² + r_y² + (r_z + 1)²)`, `s = r_x/m + ½`, `t = r_y/m + ½`.
//!
//! For unit `r`, `r_z + 1` cancels catastrophically as `r` approaches (0,0,−1) (the rim, where
//! the sampling is already stretched the most).  [`dir_to_st`] therefore uses the identity
//! `1 + r_z = (r_x² + r_y²) / (1 − r_z)` for `r_z < 0`, which is exact for unit vectors and
//! loses nothing.  (Mesh texgen, [`crate::mappings::texgen`], keeps GL's own formula on purpose.)
//!
//! ## Derivation (inverse)
//!
//! `x = 2s − 1`, `y = 2t − 1`, `d = x² + y²`, valid iff `d ≤ 1`; `z = √(1 − d)` and
//! `r = (2zx, 2zy, 2z² − 1) = (2zx, 2zy, 1 − 2d)`.
//!
//! ## Equal area
//!
//! The map is Lambert's azimuthal equal-area projection centred on the direction back at the
//! viewer: the disc radius is `sin(α/2)` for a direction at angle α from +Z, so the spherical cap
//! of half-angle α (area `2π(1 − cos α) = 4π sin²(α/2)`) fills the disc of area `π sin²(α/2)`.
//! Hence `dω = 4 dx dy = 16 ds dt`: a texel of an N×N map fully inside the disc subtends exactly
//! `16/N²` sr, a texel cut by the rim `16 × (its area inside the disc, in st units)`, and the
//! disc sums to 4π.  [`texel_solid_angle`] computes the cut area in closed form.

use crate::base::real::{dot3, Real};
use crate::frame::conventions::{pixel_to_st, st_to_pixel, Singular, SpherePreset};

/// Mirror reflection of the incident direction `u` about a surface with normal `n`:
/// `u − 2 (n·u) n`.  GL's formula: `n` is used as given (a non-unit `n` gives GL's non-unit
/// result; see `texgen` and `GL_NORMALIZE`).
#[inline]
pub fn reflect<T: Real>(u: [T; 3], n: [T; 3]) -> [T; 3] {
    let d = dot3(n, u);
    let d2 = d + d;
    [u[0] - d2 * n[0], u[1] - d2 * n[1], u[2] - d2 * n[2]]
}

/// Direction → sphere-map texture coordinates (s,t).
///
/// `r` need not be unit length.  Returns NaN for a zero or non-finite `r`; for `r` parallel to
/// (0,0,−1) (the whole rim) returns NaN or (½,½) as `singular` says.
#[inline]
pub fn dir_to_st<T: Real>(r: [T; 3], singular: Singular) -> [T; 2] {
    let l2 = dot3(r, r);
    if !(l2 > T::ZERO && l2.is_finite()) {
        return [T::NAN, T::NAN];
    }
    let inv = T::ONE / l2.sqrt();
    let (x, y, z) = (r[0] * inv, r[1] * inv, r[2] * inv);
    let q = x * x + y * y;
    // 1 + z without cancellation (exact identity for unit vectors).
    let zp1 = if z >= T::ZERO {
        T::ONE + z
    } else {
        q / (T::ONE - z)
    };
    let h2 = q + zp1 * zp1;
    if h2 == T::ZERO {
        return match singular {
            Singular::Nan => [T::NAN, T::NAN],
            Singular::Center => [T::HALF, T::HALF],
        };
    }
    let k = T::ONE / (T::TWO * h2.sqrt()); // 1/m
    [x * k + T::HALF, y * k + T::HALF]
}

/// Sphere-map texture coordinates → unit direction, or `None` outside the disc (or for
/// non-finite input).  Every point of the rim (`d = 1`) gives (0,0,−1).
#[inline]
pub fn st_to_dir<T: Real>(st: [T; 2]) -> Option<[T; 3]> {
    let x = T::TWO * st[0] - T::ONE;
    let y = T::TWO * st[1] - T::ONE;
    let d = x * x + y * y;
    if !(d <= T::ONE) {
        return None;
    }
    let z = (T::ONE - d).sqrt();
    let z2 = z + z;
    Some([z2 * x, z2 * y, T::ONE - T::TWO * d])
}

/// Solid angle (sr) of texel (`col`, `row`) of an `n`×`n` sphere map: `16 ×` the texel's area
/// inside the disc, in st units.  Texels wholly inside: exactly `16/n²`.  Row order does not
/// matter (the disc is symmetric).
pub fn texel_solid_angle(col: usize, row: usize, n: usize) -> f64 {
    let f = 2.0 / n as f64;
    let (x0, x1) = (col as f64 * f - 1.0, (col + 1) as f64 * f - 1.0);
    let (y0, y1) = (row as f64 * f - 1.0, (row + 1) as f64 * f - 1.0);
    // dω = 4 dx dy in disc coordinates.
    4.0 * rect_disc_area(x0, x1, y0, y1)
}

/// Solid angles of all texels of an `n`×`n` sphere map, row-major.
pub fn solid_angle_map(n: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(n * n);
    for row in 0..n {
        for col in 0..n {
            out.push(texel_solid_angle(col, row, n));
        }
    }
    out
}

/// Exact area of `[x0,x1]×[y0,y1] ∩ {x² + y² ≤ 1}`.
///
/// Integrates the chord length `len(x) = |[y0,y1] ∩ [−h, h]|`, `h(x) = √(1−x²)`, piecewise: the
/// breakpoints are where `h` crosses `|y0|` or `|y1|`, and on each piece `len` is one of
/// `0`, `y1−y0`, `h−y0`, `y1+h`, `2h`, whose antiderivatives are closed-form
/// (`∫h = (x h + asin x)/2`).
pub fn rect_disc_area(x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    let (x0, x1) = (x0.max(-1.0), x1.min(1.0));
    if !(x1 > x0) || !(y1 > y0) {
        return 0.0;
    }
    let mut cuts = vec![x0, x1];
    for y in [y0, y1] {
        if y.abs() < 1.0 {
            let c = (1.0 - y * y).sqrt();
            for x in [-c, c] {
                if x > x0 && x < x1 {
                    cuts.push(x);
                }
            }
        }
    }
    cuts.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let hint = |x: f64| 0.5 * (x * (1.0 - x * x).max(0.0).sqrt() + x.clamp(-1.0, 1.0).asin());
    let mut area = 0.0;
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b <= a {
            continue;
        }
        let xm = 0.5 * (a + b);
        let h = (1.0 - xm * xm).max(0.0).sqrt();
        let top_is_h = y1 >= h; // upper limit is the circle
        let bot_is_h = y0 <= -h; // lower limit is the circle
        let lo = if bot_is_h { -h } else { y0 };
        let hi = if top_is_h { h } else { y1 };
        if hi <= lo {
            continue; // the strip misses the disc on this piece
        }
        let ih = hint(b) - hint(a);
        let dx = b - a;
        area += match (top_is_h, bot_is_h) {
            (true, true) => 2.0 * ih,
            (true, false) => ih - y0 * dx,
            (false, true) => y1 * dx + ih,
            (false, false) => (y1 - y0) * dx,
        };
    }
    area
}

/// Pixels of a preset's own image (the preset is a frame convention; the disc is this mapping).
impl SpherePreset {
    /// A direction in this preset's frame → continuous pixel coordinates in this preset's image
    /// of `size`×`size`.  NaN where the direction has no single pixel (see [`Singular`]).
    pub fn dir_to_pixel(&self, d: [f64; 3], size: usize, singular: Singular) -> (f64, f64) {
        let [s, t] = dir_to_st(self.to_eye(d), singular);
        st_to_pixel(s, t, size, size, self.rows)
    }

    /// Continuous pixel coordinates in this preset's image → direction in this preset's frame,
    /// or `None` outside the disc.
    pub fn pixel_to_dir(&self, x: f64, y: f64, size: usize) -> Option<[f64; 3]> {
        let (s, t) = pixel_to_st(x, y, size, size, self.rows);
        st_to_dir([s, t]).map(|d| self.from_eye(d))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rect_disc_area_whole_and_quarter() {
        assert!((rect_disc_area(-1.0, 1.0, -1.0, 1.0) - std::f64::consts::PI).abs() < 1e-14);
        assert!((rect_disc_area(0.0, 1.0, 0.0, 1.0) - std::f64::consts::FRAC_PI_4).abs() < 1e-14);
        assert!((rect_disc_area(-0.1, 0.1, -0.1, 0.1) - 0.04).abs() < 1e-15);
        assert_eq!(rect_disc_area(0.9, 1.0, 0.9, 1.0), 0.0);
        // Strip |y| <= 0.5 across the disc: 2 * (asin(0.5) + 0.5*sqrt(0.75)).
        let want = 2.0 * ((0.5f64).asin() + 0.5 * 0.75f64.sqrt());
        assert!((rect_disc_area(-1.0, 1.0, -0.5, 0.5) - want).abs() < 1e-14);
    }
}
