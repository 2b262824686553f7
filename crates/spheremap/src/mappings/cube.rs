//! Cube maps: the six faces and their orientation (GL/KTX, and D3D as a preset).  The file
//! layouts people store them in, and the face stack, are `crate::images::cube_layout`.
//!
//! ## Faces (OpenGL 4.6 §8.13, Table 8.19; KTX, DDS and Vulkan use the same table)
//!
//! Face order +X, −X, +Y, −Y, +Z, −Z (indices 0‥5).  For a direction r the face is the axis of
//! the largest |component| (ties: x before y before z), `ma` that component, and
//!
//! ```text
//! face   sc    tc         s = (sc/|ma| + 1)/2   t = (tc/|ma| + 1)/2
//!  +X   −rz   −ry         texel (col, row) of a face image has
//!  −X   +rz   −ry         s = (col + ½)/F, t = (row + ½)/F:
//!  +Y   +rx   +rz         row 0 of every face is t = 0.
//!  −Y   +rx   −rz
//!  +Z   +rx   −ry
//!  −Z   −rx   −ry
//! ```
//!
//! Seen from inside the cube these face images are mirror images (the "RenderMan", left-handed
//! convention): the +Z face shows +X on the right although a viewer at the centre facing +Z with
//! +Y up has −X on the right.  The side faces are mirrored left-right and ±Y top-bottom.

use crate::base::error::{Error, Result};
use crate::base::real::Real;

/// Face names in GL order, as used in file patterns (`{face}`; the other schemes:
/// [`crate::images::cube_layout::FACE_TOKENS`]).
pub const FACE_NAMES: [&str; 6] = ["px", "nx", "py", "ny", "pz", "nz"];

/// The GL table: for each face, (major axis, sign), (sc axis, sign), (tc axis, sign).
const TABLE: [[(usize, f64); 3]; 6] = [
    [(0, 1.0), (2, -1.0), (1, -1.0)],
    [(0, -1.0), (2, 1.0), (1, -1.0)],
    [(1, 1.0), (0, 1.0), (2, 1.0)],
    [(1, -1.0), (0, 1.0), (2, -1.0)],
    [(2, 1.0), (0, 1.0), (1, -1.0)],
    [(2, -1.0), (0, -1.0), (1, -1.0)],
];

/// Direction → (face, s, t), s and t ∈ [0,1] within the face (t = 0 at row 0).  Face 0 with NaN
/// coordinates for a zero or non-finite direction.
#[inline(always)]
pub fn dir_to_face_st<T: Real>(d: [T; 3]) -> (usize, T, T) {
    let (ax, ay, az) = (d[0].abs(), d[1].abs(), d[2].abs());
    let (axis, ma) = if ax >= ay && ax >= az {
        (0, d[0])
    } else if ay >= az {
        (1, d[1])
    } else {
        (2, d[2])
    };
    if !(ma.abs() > T::ZERO && ma.is_finite()) {
        return (0, T::NAN, T::NAN);
    }
    let face = 2 * axis + usize::from(ma < T::ZERO);
    let [_, (si, ss), (ti, ts)] = TABLE[face];
    let inv = T::ONE / ma.abs();
    let sc = d[si] * T::from_f64(ss) * inv;
    let tc = d[ti] * T::from_f64(ts) * inv;
    (face, (sc + T::ONE) * T::HALF, (tc + T::ONE) * T::HALF)
}

/// (face, s, t) → the (unnormalized) point on the cube, ‖·‖∞ = 1 inside the face.  s and t may
/// lie outside [0,1]: the face plane extended (used to cross seams).
#[inline(always)]
pub fn face_st_to_point<T: Real>(face: usize, s: T, t: T) -> [T; 3] {
    let [(mi, ms), (si, ss), (ti, ts)] = TABLE[face];
    let mut p = [T::ZERO; 3];
    p[mi] = T::from_f64(ms);
    p[si] = (T::TWO * s - T::ONE) * T::from_f64(ss);
    p[ti] = (T::TWO * t - T::ONE) * T::from_f64(ts);
    p
}

/// (face, s, t) → unit direction.
pub fn face_st_to_dir<T: Real>(face: usize, s: T, t: T) -> [T; 3] {
    let p = face_st_to_point(face, s, t);
    let il = T::ONE / (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    [p[0] * il, p[1] * il, p[2] * il]
}

/// Exact solid angle of texel (col, row) of a face of F×F texels (same on every face).
///
/// The face is the plane at distance 1, coordinates a, b ∈ [−1,1]; the solid angle of the
/// rectangle [0,a]×[0,b] is `atan(ab / √(1 + a² + b²))`, so a texel is an inclusion–exclusion
/// of four such terms.  Σ over the cube = 4π.
pub fn texel_solid_angle(col: usize, row: usize, f: usize) -> f64 {
    let g = |a: f64, b: f64| (a * b).atan2((1.0 + a * a + b * b).sqrt());
    let c = |i: usize| 2.0 * i as f64 / f as f64 - 1.0;
    let (a0, a1, b0, b1) = (c(col), c(col + 1), c(row), c(row + 1));
    g(a1, b1) - g(a0, b1) - g(a1, b0) + g(a0, b0)
}

/// A cube-map convention: a frame change from the preset's world to ours.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CubePreset {
    pub name: &'static str,
    /// Row-major 3×3, preset frame → ours.
    pub frame: [[f64; 3]; 3],
    pub doc: &'static str,
}

pub const CUBE_PRESETS: &[CubePreset] = &[
    CubePreset {
        name: "gl",
        frame: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        doc: "OpenGL / KTX / Vulkan cube map in a right-handed Y-up world (the GL face table \
              applied to our directions). spheremap's own convention.",
    },
    CubePreset {
        name: "d3d",
        frame: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]],
        doc: "Direct3D cube map in D3D's left-handed world (+Z forward = our -Z): the same face \
              table in D3D coordinates, so the file's '+Z' face is our -Z and its face images \
              are not mirrored as seen from inside.",
    },
];

impl CubePreset {
    pub fn by_name(name: &str) -> Result<&'static CubePreset> {
        CUBE_PRESETS.iter().find(|p| p.name == name).ok_or_else(|| {
            let names: Vec<_> = CUBE_PRESETS.iter().map(|p| p.name).collect();
            Error::param(
                "preset",
                format!(
                    "unknown cube preset {name:?}; expected one of: {}",
                    names.join(", ")
                ),
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_round_trip_and_pins() {
        // Face centres.
        let axes = [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        for (i, a) in axes.iter().enumerate() {
            assert_eq!(dir_to_face_st(*a), (i, 0.5, 0.5));
        }
        // +Z face: +X to the right (s = 1), +Y at row 0 (t = 0).
        assert_eq!(dir_to_face_st([0.5, 0.0, 1.0f64]), (4, 0.75, 0.5));
        assert_eq!(dir_to_face_st([1.0, 0.0, 1.0f64]), (0, 0.0, 0.5)); // tie: x wins
        assert!((dir_to_face_st([0.0, 0.99, 1.0f64]).2 - 0.005).abs() < 1e-15); // +Y at row 0
                                                                                // +X face: −Z to the right.
        assert_eq!(dir_to_face_st([1.0, 0.0, -0.5f64]), (0, 0.75, 0.5));
        for face in 0..6 {
            for (s, t) in [(0.1, 0.2), (0.9, 0.4), (0.5, 0.99)] {
                let d = face_st_to_dir(face, s, t);
                let (f2, s2, t2) = dir_to_face_st(d);
                assert_eq!(f2, face);
                assert!((s2 - s).abs() < 1e-12 && (t2 - t).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn solid_angles_sum_to_4pi() {
        for f in [1usize, 2, 7, 64] {
            let s: f64 = (0..f)
                .flat_map(|r| (0..f).map(move |c| texel_solid_angle(c, r, f)))
                .sum();
            assert!(
                (6.0 * s - 4.0 * std::f64::consts::PI).abs() < 1e-12,
                "{f}: {s}"
            );
        }
    }
}
