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

use std::f64::consts::PI;

/// Direction (any non-zero length) → (u, v), v down.  NaN for zero or non-finite input.  +Z
/// (straight behind) is the whole rim; it is returned as the rim point on the right (u = 1).
pub fn dir_to_uv(d: [f64; 3]) -> [f64; 2] {
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if !(l > 0.0 && l.is_finite()) {
        return [f64::NAN; 2];
    }
    let (x, y, z) = (d[0] / l, d[1] / l, d[2] / l);
    let h = x.hypot(y);
    let phi = h.atan2(-z); // angle from −Z, accurate everywhere
    let (a, b) = if h > 0.0 {
        (x / h * phi / PI, y / h * phi / PI)
    } else if z < 0.0 {
        (0.0, 0.0)
    } else {
        (1.0, 0.0)
    };
    [(a + 1.0) * 0.5, (1.0 - b) * 0.5]
}

/// (u, v), v down → unit direction; `None` outside the disc or for non-finite input.
pub fn uv_to_dir(uv: [f64; 2]) -> Option<[f64; 3]> {
    let (a, b) = (2.0 * uv[0] - 1.0, 1.0 - 2.0 * uv[1]);
    let rho = a.hypot(b);
    if !(rho <= 1.0) {
        return None;
    }
    let phi = PI * rho;
    let s = if rho > 0.0 { phi.sin() / rho } else { 0.0 };
    Some([a * s, b * s, -phi.cos()])
}

/// Solid angle of texel (`col`, `row`) of an `n`×`n` angular map.
pub fn texel_solid_angle(col: usize, row: usize, n: usize) -> f64 {
    let f = 2.0 / n as f64;
    let (a0, b0) = (col as f64 * f - 1.0, row as f64 * f - 1.0);
    // Wholly outside the disc: nothing.
    let near = |lo: f64| {
        if lo > 0.0 {
            lo
        } else if lo + f < 0.0 {
            -(lo + f)
        } else {
            0.0
        }
    };
    if near(a0).hypot(near(b0)) >= 1.0 {
        return 0.0;
    }
    // Sub-cells: more where the texel is cut by the rim.
    let far = |lo: f64| lo.abs().max((lo + f).abs());
    let k = if far(a0).hypot(far(b0)) <= 1.0 { 1 } else { 16 };
    let h = f / k as f64;
    let mut sum = 0.0;
    for i in 0..k {
        for j in 0..k {
            let (ca, cb) = (a0 + (i as f64 + 0.5) * h, b0 + (j as f64 + 0.5) * h);
            for (xa, wa) in GL8 {
                for (xb, wb) in GL8 {
                    let (a, b) = (ca + 0.5 * h * xa, cb + 0.5 * h * xb);
                    let rho = a.hypot(b);
                    if rho <= 1.0 {
                        let g = if rho > 0.0 {
                            PI * (PI * rho).sin() / rho
                        } else {
                            PI * PI
                        };
                        sum += wa * wb * g;
                    }
                }
            }
        }
    }
    sum * 0.25 * h * h
}

/// 8-point Gauss–Legendre nodes and weights on [−1, 1].
const GL8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_2, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (0.960_289_856_497_536_2, 0.101_228_536_290_376_26),
];

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
