//! Debevec's angular map ("light probe" format of HDRShop and the Light Probe Image Gallery).
//!
//! Frame: ours (right-handed, +Y up, the viewer looking down −Z).  The disc's centre is the
//! direction straight **ahead, −Z**; its rim is the single direction behind, +Z; the angle from
//! −Z grows linearly with the radius.  In disc coordinates (a, b) ∈ [−1,1]², b up:
//!
//! ```text
//! r = acos(−d_z) / (π √(d_x² + d_y²)),   (a, b) = (d_x r, d_y r)
//! ```
//!
//! Image coordinates: u = (a + 1)/2, v = (1 − b)/2 (v down, row 0 at the top).  +X is to the
//! right of the centre, +Y above it.
//!
//! Solid angle: with ρ = √(a² + b²), the angle from −Z is φ = πρ and dω = sin φ dφ dθ =
//! π sin(πρ)/ρ · dA, dA = da db = 4 du dv.  [`texel_solid_angle`] integrates that over the
//! texel's part inside the disc (Gauss–Legendre on sub-cells; the integrand vanishes at the rim,
//! so the clipping costs little accuracy: the map sums to 4π within 1e-6).

use crate::base::real::Real;
use std::f64::consts::PI;

/// Direction (any non-zero length) → (u, v), v down.  NaN for zero or non-finite input.  +Z
/// (straight behind) is the whole rim; it is returned as the rim point on the right (u = 1).
#[inline(always)]
pub fn dir_to_uv<T: Real>(d: [T; 3]) -> [T; 2] {
    let l2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    if !(l2 > T::ZERO && l2.is_finite()) {
        return [T::NAN; 2];
    }
    let (x, y, z) = (d[0], d[1], d[2]);
    let h = x.hypot(y);
    let phi = h.atan2(-z) * T::from_f64(1.0 / PI); // angle from −Z / π, accurate everywhere
    let (a, b) = if h > T::ZERO {
        (x / h * phi, y / h * phi)
    } else if z < T::ZERO {
        (T::ZERO, T::ZERO)
    } else {
        (T::ONE, T::ZERO)
    };
    [(a + T::ONE) * T::HALF, (T::ONE - b) * T::HALF]
}

/// (u, v), v down → unit direction; `None` outside the disc or for non-finite input.
#[inline(always)]
pub fn uv_to_dir<T: Real>(uv: [T; 2]) -> Option<[T; 3]> {
    let (a, b) = (T::TWO * uv[0] - T::ONE, T::ONE - T::TWO * uv[1]);
    let rho = a.hypot(b);
    if !(rho <= T::ONE) {
        return None;
    }
    Some(disc_to_dir(a, b, rho))
}

/// The angular formula at disc point (a, b), radius ρ; also defined past the rim (ρ ∈ (1, 2)),
/// where it continues across the single direction +Z onto the other side.
#[inline(always)]
pub(crate) fn disc_to_dir<T: Real>(a: T, b: T, rho: T) -> [T; 3] {
    let phi = T::from_f64(PI) * rho;
    let s = if rho > T::ZERO {
        phi.sin() / rho
    } else {
        T::from_f64(PI)
    };
    [a * s, b * s, -phi.cos()]
}

/// Solid angle of texel (`col`, `row`) of an `n`×`n` angular map.
pub fn texel_solid_angle(col: usize, row: usize, n: usize) -> f64 {
    crate::base::quadrature::disc_texel_integral(col, row, n, |rho| {
        if rho > 0.0 {
            PI * (PI * rho).sin() / rho
        } else {
            PI * PI
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pinned_axes_and_round_trip() {
        let p = |d| {
            let [u, v] = dir_to_uv(d);
            (u * 64.0, v * 64.0)
        };
        assert_eq!(p([0.0, 0.0, -1.0]), (32.0, 32.0)); // ahead: centre
        let c = 16.0; // 90° from −Z: half the radius (32 px)
        let near =
            |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9;
        assert!(near(p([1.0, 0.0, 0.0]), (32.0 + c, 32.0)));
        assert!(near(p([-1.0, 0.0, 0.0]), (32.0 - c, 32.0)));
        assert!(near(p([0.0, 1.0, 0.0]), (32.0, 32.0 - c)));
        assert!(near(p([0.0, -1.0, 0.0]), (32.0, 32.0 + c)));
        assert_eq!(p([0.0, 0.0, 1.0]), (64.0, 32.0)); // behind: the rim
        for d in [[0.3f64, -0.2, 0.9], [0.1, 0.7, -0.2], [-0.5, 0.5, 0.1]] {
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let back = uv_to_dir(dir_to_uv(d)).unwrap();
            for k in 0..3 {
                assert!((back[k] - d[k] / l).abs() < 1e-12);
            }
        }
        assert!(uv_to_dir([0.0, 0.0]).is_none());
    }

    #[test]
    fn solid_angles_sum_to_4pi() {
        for n in [16usize, 64, 101] {
            let s: f64 = (0..n)
                .flat_map(|r| (0..n).map(move |c| texel_solid_angle(c, r, n)))
                .sum();
            assert!((s - 4.0 * PI).abs() < 1e-6, "n={n}: {s}");
        }
    }
}
