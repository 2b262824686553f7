//! The dual-paraboloid map (Heidrich & Seidel 1998): two discs side by side in one 2N×N image.
//!
//! Each half is the image of a paraboloid mirror `z = ½ − ½(x² + y²)` seen orthographically;
//! algebraically it is the stereographic projection of a hemisphere onto its equatorial disc.
//! Frame: ours (right-handed, +Y up, the viewer looking down −Z).
//!
//! ```text
//!   u = 0            ½             1       left half  ("front"): directions with z ≤ 0, centred
//!   +--------------+--------------+        on −Z (straight ahead), +X right, +Y up — what the
//!   |   .-'''-.    |   .-'''-.    |        viewer sees ahead;
//!   |  / −Z    \   |  / +Z    \   |        right half ("back"): z > 0, centred on +Z, −X
//!   |  \ +X →  /   |  \ −X →  /   |        right, +Y up — what the viewer sees after turning
//!   |   '-...-'    |   '-...-'    |        round.  The two rims are the same circle z = 0
//!   +--------------+--------------+        (left rim at angle α ≡ right rim at π − α).
//! ```
//!
//! In disc coordinates (a, b) ∈ unit disc, b up:
//!
//! ```text
//! front: (a, b) = (x, y) / (1 − z)        back: (a, b) = (−x, y) / (1 + z)
//! inverse, r² = a² + b²:  front d = (2a, 2b, r² − 1)/(1 + r²);  back d = (−2a, 2b, 1 − r²)/(1 + r²)
//! ```
//!
//! Image coordinates: within a half, u' = (a + 1)/2, v = (1 − b)/2 (v down); the front half is
//! u = u'/2, the back u = ½ + u'/2.
//!
//! Solid angle: dω = 4/(1 + r²)² da db; a texel at the centre subtends 4× one at the rim (the
//! ratio that makes the map attractive).  Texel solid angles are integrated exactly
//! up to quadrature error ([`crate::base::quadrature`]); both halves sum to 4π.

use crate::base::real::Real;

/// Direction (any non-zero length) → (u, v) in the 2:1 image, v down.  NaN for zero or
/// non-finite input.
#[inline(always)]
pub fn dir_to_uv<T: Real>(d: [T; 3]) -> [T; 2] {
    let l2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    if !(l2 > T::ZERO && l2.is_finite()) {
        return [T::NAN; 2];
    }
    let il = T::ONE / l2.sqrt();
    let (x, y, z) = (d[0] * il, d[1] * il, d[2] * il);
    let back = z > T::ZERO;
    // 1 ∓ z is ≥ 1 on the chosen half: no cancellation.
    let k = T::ONE / (T::ONE + z.abs());
    let a = if back { -x * k } else { x * k };
    let b = y * k;
    let uh = (a + T::ONE) * T::HALF * T::HALF;
    let u = if back { uh + T::HALF } else { uh };
    [u, (T::ONE - b) * T::HALF]
}

/// (u, v) → unit direction; `None` outside both discs or for non-finite input.
#[inline(always)]
pub fn uv_to_dir<T: Real>(uv: [T; 2]) -> Option<[T; 3]> {
    let [u, v] = uv;
    if !(u >= T::ZERO && u <= T::ONE) {
        return None;
    }
    let back = u >= T::HALF;
    let uh = if back { u - T::HALF } else { u } * T::TWO;
    let (a, b) = (T::TWO * uh - T::ONE, T::ONE - T::TWO * v);
    let r2 = a * a + b * b;
    if !(r2 <= T::ONE) {
        return None;
    }
    let k = T::ONE / (T::ONE + r2);
    let zf = (r2 - T::ONE) * k;
    Some(if back {
        [-T::TWO * a * k, T::TWO * b * k, -zf]
    } else {
        [T::TWO * a * k, T::TWO * b * k, zf]
    })
}

/// Exact (quadrature) solid angle of texel (`col`, `row`) of a 2N×N dual-paraboloid image.
pub fn texel_solid_angle(col: usize, row: usize, n: usize) -> f64 {
    crate::base::quadrature::disc_texel_integral(col % n, row, n, |rho| {
        let q = 1.0 + rho * rho;
        4.0 / (q * q)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn pinned_axes_and_round_trip() {
        let p = |d: [f64; 3]| {
            let [u, v] = dir_to_uv(d);
            (u * 128.0, v * 64.0)
        };
        assert_eq!(p([0.0, 0.0, -1.0]), (32.0, 32.0)); // ahead: front centre
        assert_eq!(p([0.0, 0.0, 1.0]), (96.0, 32.0)); // behind: back centre
        assert_eq!(p([0.0, 1.0, 0.0]), (32.0, 0.0)); // up: top of the front rim
        assert_eq!(p([1.0, 0.0, 0.0]), (64.0, 32.0)); // +X: right of the front rim
        assert_eq!(p([1.0, 0.0, 1e-300]), (64.0, 32.0)); // …and left of the back rim
        let (x, y) = p([-1.0, 0.0, 1e-9]); // −X: right rim of the back
        assert!((x - 128.0).abs() < 1e-6 && y == 32.0);
        assert!(p([0.0, 0.0, 0.0]).0.is_nan());
        for d in [
            [0.3f64, -0.2, 0.9],
            [0.1, 0.7, -0.2],
            [-0.5, 0.5, 0.1],
            [0.0, -1.0, 0.0],
        ] {
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let back = uv_to_dir(dir_to_uv(d)).unwrap();
            for k in 0..3 {
                assert!((back[k] - d[k] / l).abs() < 1e-12, "{d:?} {back:?}");
            }
        }
        assert!(uv_to_dir([0.0, 0.0]).is_none());
        assert!(uv_to_dir([0.55, 0.05]).is_none());
        assert!(uv_to_dir([0.75, 0.99]).is_some()); // back disc, near its bottom
    }

    #[test]
    fn solid_angles_sum_to_4pi_and_ratio_is_4() {
        for n in [16usize, 63, 128] {
            let s: f64 = (0..n)
                .flat_map(|r| (0..2 * n).map(move |c| texel_solid_angle(c, r, n)))
                .sum();
            assert!((s - 4.0 * PI).abs() < 1e-6, "n={n}: {s}");
        }
        let n = 256;
        let centre = texel_solid_angle(n / 2, n / 2, n);
        let rim = texel_solid_angle(n / 2, 1, n); // wholly inside, next to the rim
        let rho = 1.0 - 3.0 / n as f64; // its centre's radius
        let want = (1.0 + rho * rho).powi(2); // → 4 at the rim
        assert!(
            (centre / rim / want - 1.0).abs() < 1e-4,
            "{} {want}",
            centre / rim
        );
    }
}
