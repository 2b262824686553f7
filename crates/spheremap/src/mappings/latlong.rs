//! The lat-long (equirectangular) mapping, a family of presets.
//!
//! World frame: right-handed, +Y up (our eye frame when the viewer looks down −Z).  Image
//! coordinates `(u, v) ∈ [0,1]²`, `u = x/W` to the right, `v = y/H` **down** (row 0 at the top,
//! as the files are stored; see [`crate::frame::conventions`]).
//!
//! ```text
//! v = acos(y) / π                          top row +Y, bottom row −Y
//! u = (u₊ₓ + atan2(z, x) / 2π)  mod 1       u₊ₓ: where the preset puts +X
//! ```
//!
//! ```text
//!   u = 0         ¼          ½          ¾          1        (preset "blender", u₊ₓ = ½)
//!   +-----------------------------------------------+  v = 0  (+Y, the zenith)
//!   |   −X        −Z         +X         +Z      −X  |
//!   +-----------------------------------------------+  v = 1  (−Y, the nadir)
//! ```
//!
//! Every preset runs the same way round (−Z → +X → +Z as u grows: the world seen from inside,
//! not mirrored); they differ only in where +X sits.  Checked against each tool's source:
//!
//! | preset | u₊ₓ | centre column | source |
//! |---|---|---|---|
//! | `blender` (default), `threejs` | ½ | +X | Cycles `direction_to_equirectangular` (Z-up, converted to Y-up), three.js `equirectUv` |
//! | `skylibs`, `filament` | ¾ | −Z | skylibs `world2latlong`: u = ½ + atan2(x, −z)/2π; Filament cmgen: same |
//! | `mitsuba` | ¼ | +Z | Mitsuba 3 `envmap`: u = atan2(x, −z)/2π |
//! | `pbrt` | 0 | −X | pbrt-v3 `InfiniteAreaLight` (Z-up light space: φ = atan2(y, x), θ = acos z) with the usual Y-up ↔ Z-up axis swap |
//!
//! Wrap rule: u wraps (the seam at u = 0 ≡ 1 is continuous); stepping past a pole (v < 0 or
//! v > 1) reflects v and turns u by ½ — [`wrap`].
//!
//! Texel solid angle, exact: a texel spans Δφ = 2π/W and the polar band θ₀..θ₁ (θ = πv), so
//! `ω = (2π/W)(cos θ₀ − cos θ₁)`; a row's texels are equal, and the map sums to 4π.

use crate::base::error::{Error, Result};
use crate::base::real::Real;
use std::f64::consts::{PI, TAU};

/// A lat-long convention.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LatLongPreset {
    pub name: &'static str,
    /// u of the direction +X.
    pub u_plus_x: f64,
    pub doc: &'static str,
}

pub const LATLONG_PRESETS: &[LatLongPreset] = &[
    LatLongPreset {
        name: "blender",
        u_plus_x: 0.5,
        doc: "Blender Environment Texture / three.js: centre column +X",
    },
    LatLongPreset {
        name: "threejs",
        u_plus_x: 0.5,
        doc: "three.js equirectangular textures (same as blender)",
    },
    LatLongPreset {
        name: "skylibs",
        u_plus_x: 0.75,
        doc: "skylibs latlong: centre column -Z",
    },
    LatLongPreset {
        name: "filament",
        u_plus_x: 0.75,
        doc: "Filament cmgen equirect: centre column -Z (same as skylibs)",
    },
    LatLongPreset {
        name: "mitsuba",
        u_plus_x: 0.25,
        doc: "Mitsuba 3 envmap: centre column +Z",
    },
    LatLongPreset {
        name: "pbrt",
        u_plus_x: 0.0,
        doc: "pbrt-v3 infinite light with Y-up <-> Z-up axis swap: +X at u = 0",
    },
];

impl LatLongPreset {
    pub fn by_name(name: &str) -> Result<&'static LatLongPreset> {
        LATLONG_PRESETS
            .iter()
            .find(|p| p.name == name)
            .ok_or_else(|| {
                let names: Vec<_> = LATLONG_PRESETS.iter().map(|p| p.name).collect();
                Error::param(
                    "preset",
                    format!(
                        "unknown lat-long preset {name:?}; expected one of: {}",
                        names.join(", ")
                    ),
                )
            })
    }

    /// Direction (any non-zero length) → (u, v), v down.  NaN for zero or non-finite input.
    /// Generic: f64 is the reference, f32 the fast path (polynomial atan2, see [`Real::atan2`]).
    #[inline(always)]
    pub fn dir_to_uv<T: Real>(&self, d: [T; 3]) -> [T; 2] {
        let l2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        if !(l2 > T::ZERO && l2.is_finite()) {
            return [T::NAN; 2];
        }
        // atan2 of (z, x) is 0 at the poles (x = z = 0): any u is right there.
        let u = T::from_f64(self.u_plus_x) + d[2].atan2(d[0]) * T::from_f64(1.0 / TAU);
        let u = u - u.floor();
        // acos loses accuracy near the poles; atan2 of (horizontal length, y) does not.
        let v = d[0].hypot(d[2]).atan2(d[1]) * T::from_f64(1.0 / PI);
        [if u >= T::ONE { T::ZERO } else { u }, v]
    }

    /// (u, v) → unit direction; `None` for v outside [0,1] or non-finite input (u wraps).
    #[inline(always)]
    pub fn uv_to_dir<T: Real>(&self, uv: [T; 2]) -> Option<[T; 3]> {
        let [u, v] = uv;
        if !(u.is_finite() && v >= T::ZERO && v <= T::ONE) {
            return None;
        }
        let phi = (u - T::from_f64(self.u_plus_x)) * T::from_f64(TAU);
        let theta = v * T::from_f64(PI);
        let s = theta.sin();
        Some([s * phi.cos(), theta.cos(), s * phi.sin()])
    }
}

/// Wraps continuous image coordinates onto the lat-long's domain: u modulo 1; past a pole, v is
/// reflected and u turned by ½ (the other side of the pole).
pub fn wrap(u: f64, v: f64) -> (f64, f64) {
    let v2 = v.rem_euclid(2.0);
    let (v, flip) = if v2 > 1.0 {
        (2.0 - v2, true)
    } else {
        (v2, false)
    };
    let u = if flip { u + 0.5 } else { u };
    (u.rem_euclid(1.0), v)
}

/// Exact solid angle of a texel in row `row` of a `width`×`height` lat-long image.
pub fn texel_solid_angle(row: usize, width: usize, height: usize) -> f64 {
    let t0 = PI * row as f64 / height as f64;
    let t1 = PI * (row + 1) as f64 / height as f64;
    TAU / width as f64 * (t0.cos() - t1.cos())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_sum_to_4pi() {
        for (w, h) in [(8, 4), (2048, 1024), (7, 5)] {
            let s: f64 = (0..h).map(|r| w as f64 * texel_solid_angle(r, w, h)).sum();
            assert!((s - 4.0 * PI).abs() < 1e-12, "{w}x{h}: {s}");
        }
    }

    #[test]
    fn wrap_rules() {
        assert_eq!(wrap(1.25, 0.5), (0.25, 0.5));
        assert_eq!(wrap(-0.25, 0.5), (0.75, 0.5));
        let (u, v) = wrap(0.1, -0.1);
        assert!((u - 0.6).abs() < 1e-15 && (v - 0.1).abs() < 1e-15);
        let (u, v) = wrap(0.9, 1.2);
        assert!((u - 0.4).abs() < 1e-15 && (v - 0.8).abs() < 1e-15);
    }
}
