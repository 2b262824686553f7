//! The materials a map lights: Lambert and GGX (Trowbridge–Reitz) with height-correlated Smith
//! masking-shadowing and Fresnel 1, their directional albedo, and the GGX visible-normal sampler.
//!
//! With n the surface normal, v the direction to the viewer, l the direction to the light and
//! h = normalize(l + v), every formula is written for the BRDF **times the cosine**,
//! f(l, v)·(n·l), the quantity integrated against the environment's radiance:
//!
//! * Lambert: f·(n·l) = (n·l)/π.
//! * GGX, α = roughness² (the perceptual roughness of glTF, Blender and Filament):
//!   D(h) = α² / (π ((n·h)²(α² − 1) + 1)²);
//!   Λ(ω) = (√(1 + α² tan²θ_ω) − 1)/2, G₂(l, v) = 1/(1 + Λ(l) + Λ(v)) (height-correlated);
//!   f = D G₂ / (4 (n·l)(n·v)), so f·(n·l) = D · V · (n·l) with the visibility term
//!   V = G₂/(4 (n·l)(n·v)) = ½ / ((n·l)√((n·v)²(1 − α²) + α²) + (n·v)√((n·l)²(1 − α²) + α²)).
//!
//! The directional albedo E(μ) = ∫ f·(n·l) dω_l (μ = n·v) is what a white environment of
//! radiance 1 reflects; [`Albedo`] tabulates it by a quadrature over the half vector
//! (Gauss–Legendre, [`ggx_albedo`]), to about 1e-6.

use crate::base::vec::{cross, dot, normalize};
use std::f64::consts::PI;

crate::base::named::named_enum! {
    /// The names of [`Material`].
    #[derive(Default)]
    pub enum MaterialName: "material" as "material" {
        Lambert = "lambert" | "diffuse",
        #[default]
        Ggx = "ggx",
    }
}

/// A material: what `bake-matcap --material` and `prefilter` name.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    /// The Lambert (cosine) lobe.
    Lambert,
    /// The GGX lobe with this α (= roughness²).
    Ggx { alpha: f64 },
}

impl Material {
    /// The material from its name and perceptual roughness (ignored for `lambert`).
    pub fn parse(name: &str, roughness: f64) -> crate::base::error::Result<Material> {
        Material::of(MaterialName::parse(name)?, roughness)
    }

    /// The material named `name`, of perceptual roughness `roughness` (ignored for
    /// `lambert`).
    pub fn of(name: MaterialName, roughness: f64) -> crate::base::error::Result<Material> {
        match name {
            MaterialName::Lambert => Ok(Material::Lambert),
            MaterialName::Ggx => {
                if !(0.0..=1.0).contains(&roughness) {
                    return Err(crate::base::error::Error::param(
                        "roughness",
                        format!("{roughness} is out of range 0..=1"),
                    ));
                }
                Ok(Material::Ggx {
                    alpha: roughness * roughness,
                })
            }
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Material::Lambert => "lambert",
            Material::Ggx { .. } => "ggx",
        }
    }

    /// The albedo when none is given: 0.8 grey for Lambert, white for GGX.
    pub fn default_albedo(self) -> [f64; 3] {
        match self {
            Material::Lambert => [0.8; 3],
            Material::Ggx { .. } => [1.0; 3],
        }
    }
}

/// The GGX distribution D(h) from c = n·h.
#[inline]
pub fn ggx_d(alpha: f64, c: f64) -> f64 {
    let a2 = alpha * alpha;
    let k = c * c * (a2 - 1.0) + 1.0;
    a2 / (PI * k * k)
}

/// [`ggx_d`] from the squared cosine `c2` (where it is known without a root).
#[inline]
pub fn ggx_d_sq(alpha: f64, c2: f64) -> f64 {
    let a2 = alpha * alpha;
    let k = c2 * (a2 - 1.0) + 1.0;
    a2 / (PI * k * k)
}

/// Smith's Λ for GGX at cosine μ (> 0) to the normal.
#[inline]
pub fn smith_lambda(alpha: f64, mu: f64) -> f64 {
    let mu2 = mu * mu;
    let tan2 = ((1.0 - mu2) / mu2).max(0.0);
    0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
}

/// The height-correlated masking-shadowing G₂ for cosines μ_l, μ_v (> 0).
#[inline]
pub fn smith_g2(alpha: f64, mu_l: f64, mu_v: f64) -> f64 {
    1.0 / (1.0 + smith_lambda(alpha, mu_l) + smith_lambda(alpha, mu_v))
}

/// The visibility term V = G₂/(4 μ_l μ_v) in the form that is finite at grazing angles.
#[inline]
pub fn ggx_visibility(alpha: f64, mu_l: f64, mu_v: f64) -> f64 {
    let a2 = alpha * alpha;
    let gv = mu_l * (mu_v * mu_v * (1.0 - a2) + a2).sqrt();
    let gl = mu_v * (mu_l * mu_l * (1.0 - a2) + a2).sqrt();
    0.5 / (gv + gl)
}

/// f·(n·l) for unit n, v, l (0 below the horizon of n or behind the viewer's).
#[inline(always)]
pub fn eval_cos(m: Material, n: [f64; 3], v: [f64; 3], l: [f64; 3]) -> f64 {
    let mu_l = dot(n, l);
    if !(mu_l > 0.0) {
        return 0.0;
    }
    match m {
        Material::Lambert => mu_l / PI,
        Material::Ggx { alpha } => {
            let mu_v = dot(n, v).max(1e-9);
            let h = [l[0] + v[0], l[1] + v[1], l[2] + v[2]];
            let hl = dot(h, h);
            if !(hl > 0.0) {
                return 0.0;
            }
            let nh = dot(n, h) / hl.sqrt();
            ggx_d(alpha, nh) * ggx_visibility(alpha, mu_l, mu_v) * mu_l
        }
    }
}

/// An orthonormal frame (t, b) completing unit `n` (Duff et al. 2017, branchless).
#[inline]
pub fn tangent_frame(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let s = 1f64.copysign(n[2]);
    let a = -1.0 / (s + n[2]);
    let b = n[0] * n[1] * a;
    (
        [1.0 + s * n[0] * n[0] * a, s * b, -s * n[0]],
        [b, s + n[1] * n[1] * a, -n[1]],
    )
}

/// The GGX directional albedo E(μ) = ∫ f·(n·l) dω_l at μ = n·v, Fresnel 1, by an m×m
/// Gauss–Legendre quadrature over the half vector: φ over [0, π] (the integrand is even in φ),
/// and for each φ, θ_h from 0 to where l meets the horizon, θ_c = π/4 + ½ atan2(cos φ √(1 − μ²), μ)
/// (there n·l = 0), in the variable u with D's CDF ξ = sin²(πu/2) (so D's peak and tail are
/// both resolved).  The integrand is smooth on that domain: m = 64 gives about 1e-8 except at
/// grazing μ (1e-4 at μ = 0.02).
pub fn ggx_albedo(alpha: f64, mu: f64, m: usize) -> f64 {
    let mut e = 0.0;
    ggx_quadrature(alpha, mu, m, |w, _| e += w);
    e
}

/// The quadrature of [`ggx_albedo`], point by point: `f(weight, v·h)` for each half vector,
/// the weights summing to E(μ) (the split-sum table weighs them by Fresnel).
pub fn ggx_quadrature(alpha: f64, mu: f64, m: usize, mut f: impl FnMut(f64, f64)) {
    let mu = mu.clamp(1e-6, 1.0);
    let sv = (1.0 - mu * mu).max(0.0).sqrt();
    let v = [sv, 0.0, mu];
    let a2 = alpha * alpha;
    let (x, w) = crate::base::quadrature::gauss_legendre(m);
    for (xp, wp) in x.iter().zip(&w) {
        let phi = (xp + 1.0) * 0.5 * PI;
        let (sp, cp) = phi.sin_cos();
        let th_c = PI / 4.0 + 0.5 * (cp * sv).atan2(mu);
        let t = th_c.tan().powi(2) / a2;
        let xi_c = t / (1.0 + t);
        let u_c = 2.0 / PI * xi_c.sqrt().min(1.0).asin();
        for (xu, wu) in x.iter().zip(&w) {
            let u = (xu + 1.0) * 0.5 * u_c;
            let xi = (PI * u / 2.0).sin().powi(2);
            let jac = PI / 2.0 * (PI * u).sin();
            // D(h)(n·h) dω_h has CDF ξ in cos²θ_h = (1 − ξ)/(1 + (α² − 1)ξ).
            let c2 = (1.0 - xi) / (1.0 + (a2 - 1.0) * xi);
            let (ch, sh) = (c2.sqrt(), (1.0 - c2).max(0.0).sqrt());
            let h = [sh * cp, sh * sp, ch];
            let vh = dot(v, h);
            let mu_l = 2.0 * vh * ch - mu;
            if mu_l <= 0.0 || vh <= 0.0 {
                continue;
            }
            // f·(n·l) dω_l = D V μ_l · 4 (v·h) dω_h = [4 V μ_l (v·h) / (n·h)] · D (n·h) dω_h.
            let value = 4.0 * ggx_visibility(alpha, mu_l, mu) * mu_l * vh / ch;
            f(wp * 0.5 * wu * 0.5 * u_c * jac * value, vh);
        }
    }
}

/// E(μ) of one material, tabulated for fast lookups (Lambert: 1).
#[derive(Clone, Debug)]
pub struct Albedo {
    /// E at μ = (k/(K−1))², k = 0..K (denser near grazing).
    table: Vec<f64>,
}

impl Albedo {
    const K: usize = 257;

    pub fn new(m: Material) -> Albedo {
        use rayon::prelude::*;
        match m {
            Material::Lambert => Albedo { table: Vec::new() },
            Material::Ggx { alpha } => Albedo {
                table: (0..Self::K)
                    .into_par_iter()
                    .map(|k| {
                        let u = k as f64 / (Self::K - 1) as f64;
                        ggx_albedo(alpha, (u * u).max(1e-6), if u < 0.3 { 192 } else { 64 })
                    })
                    .collect(),
            },
        }
    }

    /// E(μ) (Catmull–Rom in √μ).
    pub fn at(&self, mu: f64) -> f64 {
        if self.table.is_empty() {
            return 1.0;
        }
        let t = &self.table;
        let x = mu.clamp(0.0, 1.0).sqrt() * (Self::K - 1) as f64;
        let i = (x.floor() as usize).min(Self::K - 2);
        let f = x - i as f64;
        // Beyond the ends, the line through the last two entries.
        let last = Self::K as isize - 1;
        let p = |k: isize| match k {
            k if k < 0 => 2.0 * t[0] - t[1],
            k if k > last => 2.0 * t[last as usize] - t[last as usize - 1],
            k => t[k as usize],
        };
        let (p0, p1, p2, p3) = (
            p(i as isize - 1),
            p(i as isize),
            p(i as isize + 1),
            p(i as isize + 2),
        );
        p1 + 0.5
            * f
            * (p2 - p0
                + f * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + f * (3.0 * (p1 - p2) + p3 - p0)))
    }
}

/// A GGX visible normal (Heitz 2018) for view `v` given in the frame of the normal (z up),
/// from uniform (u1, u2): returns the microfacet normal in that frame.
#[inline]
pub fn sample_vndf(alpha: f64, v: [f64; 3], u1: f64, u2: f64) -> [f64; 3] {
    let vh = normalize([alpha * v[0], alpha * v[1], v[2]]);
    let lensq = vh[0] * vh[0] + vh[1] * vh[1];
    let t1 = if lensq > 0.0 {
        let k = 1.0 / lensq.sqrt();
        [-vh[1] * k, vh[0] * k, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let t2 = cross(vh, t1);
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let p1 = r * phi.cos();
    let mut p2 = r * phi.sin();
    let s = 0.5 * (1.0 + vh[2]);
    p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
    let pz = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    let nh = [
        p1 * t1[0] + p2 * t2[0] + pz * vh[0],
        p1 * t1[1] + p2 * t2[1] + pz * vh[1],
        p1 * t1[2] + p2 * t2[2] + pz * vh[2],
    ];
    normalize([alpha * nh[0], alpha * nh[1], nh[2].max(1e-9)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lambert_albedo_is_one_and_ggx_below_one() {
        assert_eq!(Albedo::new(Material::Lambert).at(0.3), 1.0);
        for alpha in [0.01, 0.0625, 0.25, 1.0] {
            for mu in [0.05, 0.5, 1.0] {
                let e = ggx_albedo(alpha, mu, 64);
                assert!(e > 0.3 && e <= 1.0 + 1e-9, "alpha {alpha} mu {mu}: {e}");
                // Converged: more points change nothing.
                let f = ggx_albedo(alpha, mu, 128);
                assert!((e - f).abs() < 2e-5, "alpha {alpha} mu {mu}: {e} vs {f}");
            }
        }
        // Smooth surfaces lose almost nothing to masking at normal incidence.
        assert!((ggx_albedo(1e-4, 1.0, 64) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn the_table_matches_the_quadrature() {
        for alpha in [0.04, 0.25, 0.7] {
            let t = Albedo::new(Material::Ggx { alpha });
            for mu in [0.013, 0.2, 0.577, 0.93] {
                let (a, b) = (t.at(mu), ggx_albedo(alpha, mu, 256));
                assert!(
                    (a - b).abs() < 1e-5 * b,
                    "alpha {alpha} mu {mu}: {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn vndf_estimates_the_albedo() {
        // E = E_vndf[G₂/G₁(v)]: a second route to the same number.
        let (alpha, mu): (f64, f64) = (0.3, 0.6);
        let v = [(1.0 - mu * mu).sqrt(), 0.0, mu];
        let n = 256;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let h = sample_vndf(
                    alpha,
                    v,
                    (i as f64 + 0.5) / n as f64,
                    (j as f64 + 0.5) / n as f64,
                );
                let vh = dot(v, h);
                let l = [
                    2.0 * vh * h[0] - v[0],
                    2.0 * vh * h[1] - v[1],
                    2.0 * vh * h[2] - v[2],
                ];
                if l[2] > 0.0 {
                    sum += (1.0 + smith_lambda(alpha, mu)) * smith_g2(alpha, l[2], mu);
                }
            }
        }
        let e = sum / (n * n) as f64;
        let q = ggx_albedo(alpha, mu, 64);
        assert!((e - q).abs() < 1e-4, "{e} vs {q}");
    }

    #[test]
    fn visibility_is_g2_over_4_cosines() {
        for (alpha, ml, mv) in [(0.1, 0.3, 0.9), (0.7, 0.05, 0.5), (1.0, 1.0, 1.0)] {
            let a = ggx_visibility(alpha, ml, mv);
            let b = smith_g2(alpha, ml, mv) / (4.0 * ml * mv);
            assert!((a - b).abs() < 1e-12 * b);
        }
    }
}
