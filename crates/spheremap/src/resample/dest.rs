//! The destination side of a conversion: canvas point → direction, with the gutter.

use super::options::Outside;
use crate::base::real::Real;
use crate::mappings::mapping::Mapping;

/// The destination side: canvas point → direction (in the source's frame), with the gutter.
pub(crate) struct Dst<T: Real> {
    pub(crate) m: Mapping,
    pub(crate) wf: T,
    pub(crate) hf: T,
    pub(crate) rot: [[T; 3]; 3],
    pub(crate) outside: Outside,
    /// The density varies across the canvas (so samples must be weighted by it).
    pub(crate) weighted: bool,
}

impl<T: Real> Dst<T> {
    /// A `w`×`h` canvas of `m`; `rotation` takes its directions to the source's frame.
    pub(crate) fn new(
        m: Mapping,
        w: usize,
        h: usize,
        rotation: &[[f64; 3]; 3],
        outside: Outside,
    ) -> Self {
        Dst {
            m,
            wf: T::from_f64(w as f64),
            hf: T::from_f64(h as f64),
            rot: rotation.map(|r| r.map(T::from_f64)),
            outside,
            weighted: !matches!(m, Mapping::Sphere(_) | Mapping::Octahedral),
        }
    }

    /// The sample weight's density factor at a canvas point (1 for equal-area mappings).
    #[inline]
    pub(crate) fn density(&self, px: T, py: T) -> f64 {
        if self.weighted {
            self.m.density([px / self.wf, py / self.hf]).to_f64()
        } else {
            1.0
        }
    }

    /// Canvas pixel position → (direction in source frame, counts as on the map).  Off-map
    /// points are mirrored across the rim (gutter) and flagged.
    #[inline(always)]
    pub(crate) fn dir(&self, px: T, py: T) -> ([T; 3], bool) {
        let uv = [px / self.wf, py / self.hf];
        let (d, on) = match self.m.uv_to_dir(uv) {
            Some(d) => (d, true),
            None => (self.mirrored(uv), false),
        };
        let r = &self.rot;
        let rd = [
            r[0][0] * d[0] + r[0][1] * d[1] + r[0][2] * d[2],
            r[1][0] * d[0] + r[1][1] * d[1] + r[1][2] * d[2],
            r[2][0] * d[0] + r[2][1] * d[1] + r[2][2] * d[2],
        ];
        (rd, on)
    }

    /// The direction of the radial mirror image (across the rim) of an off-map canvas point.
    #[cold]
    fn mirrored(&self, uv: [T; 2]) -> [T; 3] {
        let one = T::ONE;
        // A point beyond the canvas (a tent or Gaussian sample of an edge texel) is mirrored
        // radially like any other: clamping it onto the canvas first would turn its angle
        // (and the vectorized path, `rows::sphere_dir`, does not clamp).  The paraboloid
        // keeps its clamp of v (as before; it has no vectorized path to agree with).
        let clamp = |v: T| v.max(T::ZERO).min(one);
        let (half, v, back) = match self.m {
            Mapping::Paraboloid => {
                let back = uv[0] >= T::HALF;
                let uh = if back { uv[0] - T::HALF } else { uv[0] } * T::TWO;
                (uh, clamp(uv[1]), back)
            }
            _ => (uv[0], uv[1], false),
        };
        let (a, b) = (T::TWO * half - one, T::TWO * v - one);
        let rho = a.hypot(b);
        if !(rho > T::ZERO) {
            return self
                .m
                .uv_to_dir([T::HALF, T::HALF])
                .unwrap_or([T::ZERO, T::ZERO, -one]);
        }
        // ρ' = 2 − ρ, kept a hair inside the disc.
        let k = (T::TWO - rho).max(T::ZERO).min(one - T::from_f64(1e-6)) / rho;
        let (a2, b2) = (a * k, b * k);
        let h2 = (a2 + one) * T::HALF;
        let u2 = match self.m {
            Mapping::Paraboloid if back => h2 * T::HALF + T::HALF,
            Mapping::Paraboloid => h2 * T::HALF,
            _ => h2,
        };
        self.m
            .uv_to_dir([u2, (b2 + one) * T::HALF])
            .unwrap_or([T::ZERO, T::ZERO, -one])
    }
}
