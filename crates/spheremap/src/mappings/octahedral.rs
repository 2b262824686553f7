//! The equal-area octahedral map of pbrt-v4 (Clarberg's concentric octahedral mapping,
//! `EqualAreaSquareToSphere` / `EqualAreaSphereToSquare`), with exact `atan` where pbrt uses a
//! polynomial fit.
//!
//! Native frame (pbrt's, z up): the +Z hemisphere fills the central diamond, −Z the four corner
//! triangles; image coordinates (u, v) = p, v = row/H (row 0 at the top, as pbrt stores images).
//! From our Y-up frame the `pbrt` preset uses the same axis swap as the lat-long `pbrt` preset:
//! pbrt (x, y, z) = ours (x, z, y), so our +Y (up) is the centre of the image.
//!
//! Equal area: every texel of an N×N map subtends exactly 4π/N².
//!
//! Wrap rule (pbrt's `WrapMode::OctahedralSphere`): past the left or right edge, u reflects and v
//! flips (v → 1 − v); past the top or bottom edge, v reflects and u flips.

use crate::base::real::Real;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

/// Direction (ours, any non-zero length) → (u, v), v down.  NaN for zero/non-finite input.
#[inline(always)]
pub fn dir_to_uv<T: Real>(d: [T; 3]) -> [T; 2] {
    let l2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    if !(l2 > T::ZERO && l2.is_finite()) {
        return [T::NAN; 2];
    }
    let il = T::ONE / l2.sqrt();
    // Ours → pbrt's frame: pbrt (x, y, z) = ours (x, z, y).
    let (dx, dy, dz) = (d[0] * il, d[2] * il, d[1] * il);
    let (x, y, z) = (dx.abs(), dy.abs(), dz.abs());
    let r = (T::ONE - z).max(T::ZERO).sqrt();
    // φ/(π/2) = atan(min/max)/(π/2), mirrored past the diagonal.
    let mut phi = x.min(y).atan2(x.max(y)) * T::from_f64(1.0 / FRAC_PI_2);
    if x < y {
        phi = T::ONE - phi;
    }
    let mut v = phi * r;
    let mut u = r - v;
    if dz < T::ZERO {
        std::mem::swap(&mut u, &mut v);
        u = T::ONE - u;
        v = T::ONE - v;
    }
    let (u, v) = (u.copysign(dx), v.copysign(dy));
    [T::HALF * (u + T::ONE), T::HALF * (v + T::ONE)]
}

/// (u, v) ∈ [0,1]², v down → unit direction (ours); `None` outside the square or non-finite.
#[inline(always)]
pub fn uv_to_dir<T: Real>(uv: [T; 2]) -> Option<[T; 3]> {
    if !(uv[0] >= T::ZERO && uv[0] <= T::ONE && uv[1] >= T::ZERO && uv[1] <= T::ONE) {
        return None;
    }
    let (u, v) = (T::TWO * uv[0] - T::ONE, T::TWO * uv[1] - T::ONE);
    let (up, vp) = (u.abs(), v.abs());
    let signed_distance = T::ONE - (up + vp);
    let r = T::ONE - signed_distance.abs();
    let phi = if r == T::ZERO {
        T::ONE
    } else {
        (vp - up) / r + T::ONE
    } * T::from_f64(FRAC_PI_4);
    let z = (T::ONE - r * r).copysign(signed_distance);
    let (cos_phi, sin_phi) = (phi.cos().copysign(u), phi.sin().copysign(v));
    let k = r * (T::TWO - r * r).max(T::ZERO).sqrt();
    let (x, y) = (cos_phi * k, sin_phi * k);
    // pbrt (x, y, z) → ours (x, z, y).
    Some([x, z, y])
}

/// Exact solid angle of any texel of an `n`×`n` octahedral map: 4π/n².
pub fn texel_solid_angle(n: usize) -> f64 {
    4.0 * std::f64::consts::PI / (n * n) as f64
}

/// Folds continuous image coordinates back onto the map (pbrt's octahedral wrap).
pub fn wrap(mut u: f64, mut v: f64) -> (f64, f64) {
    for _ in 0..4 {
        if u < 0.0 {
            u = -u;
            v = 1.0 - v;
        } else if u > 1.0 {
            u = 2.0 - u;
            v = 1.0 - v;
        }
        if v < 0.0 {
            v = -v;
            u = 1.0 - u;
        } else if v > 1.0 {
            v = 2.0 - v;
            u = 1.0 - u;
        }
    }
    (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pinned_axes() {
        let p = |d| {
            let [u, v] = dir_to_uv(d);
            (u * 64.0, v * 64.0)
        };
        assert_eq!(p([0.0, 1.0, 0.0]), (32.0, 32.0)); // our up: pbrt +Z, the centre
        assert_eq!(p([1.0, 0.0, 0.0]), (64.0, 32.0)); // +X: right corner of the diamond
        assert_eq!(p([-1.0, 0.0, 0.0]), (0.0, 32.0));
        assert_eq!(p([0.0, 0.0, 1.0]), (32.0, 64.0)); // our +Z: pbrt +Y, v = 1 (bottom)
        assert_eq!(p([0.0, 0.0, -1.0]), (32.0, 0.0));
        let (x, y) = p([0.0, -1.0, 0.0]); // our down: a corner (all four are the same point)
        assert!((x == 0.0 || x == 64.0) && (y == 0.0 || y == 64.0));
    }

    #[test]
    fn round_trips_and_wrap_continuity() {
        let mut s = 0x1234_5678_9abc_def0u64;
        let mut rnd = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..20_000 {
            let d = [rnd(), rnd(), rnd()];
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            if l < 1e-3 {
                continue;
            }
            let back = uv_to_dir(dir_to_uv(d)).unwrap();
            for k in 0..3 {
                assert!((back[k] - d[k] / l).abs() < 1e-9, "{d:?} {back:?}");
            }
            let uv = [0.5 * (rnd() + 1.0), 0.5 * (rnd() + 1.0)];
            let again = dir_to_uv(uv_to_dir(uv).unwrap());
            assert!(
                (again[0] - uv[0]).abs() < 1e-9 && (again[1] - uv[1]).abs() < 1e-9,
                "{uv:?} {again:?}"
            );
        }
        // Folding across an edge lands on the direction continuing across it: the distance to
        // the edge point shrinks in proportion to the step (the map stretches up to ~5× there).
        for eps in [1e-3f64, 1e-6] {
            for (u, v) in [(-eps, 0.3), (1.0 + eps, 0.7), (0.2, -eps), (0.6, 1.0 + eps)] {
                let edge = uv_to_dir([u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)]).unwrap();
                let (wu, wv) = wrap(u, v);
                let folded = uv_to_dir([wu, wv]).unwrap();
                let dist: f64 = (0..3)
                    .map(|k| (edge[k] - folded[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(dist < 10.0 * eps, "({u},{v}) -> ({wu},{wv}): {dist}");
            }
        }
    }
}
