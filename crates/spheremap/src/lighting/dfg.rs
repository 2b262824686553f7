//! The split-sum DFG lookup table (Karis 2013) for the GGX of [`super::brdf`] (height-correlated
//! Smith G₂), for engines that light with the split-sum approximation.
//!
//! With Schlick's Fresnel F = F₀ + (1 − F₀)(1 − v·h)⁵, the directional albedo splits as
//! E(μ) = F₀·A(μ, r) + B(μ, r):
//! A = ∫ (1 − (1 − v·h)⁵) f₁·(n·l) dω, B = ∫ (1 − v·h)⁵ f₁·(n·l) dω, f₁ the lobe with F = 1.
//!
//! The table is N×N, row 0 first (the image's top row): texel (i, j) holds μ = n·v = (i+½)/N and
//! perceptual roughness r = (j+½)/N (α = r²); channel 0 is A, channel 1 is B, and channel 2 is
//! A + B, the directional albedo with F = 1 (what multiple-scattering energy compensation divides
//! by).  Each value is the quadrature of [`super::brdf::ggx_albedo`] (Gauss–Legendre over the half
//! vector).

use super::brdf;
use crate::base::error::Result;
use crate::images::Image;
use rayon::prelude::*;

/// The default table size.
pub const DEFAULT_SIZE: usize = 128;

/// (A, B) at cosine `mu` and α, by the m×m quadrature of [`brdf::ggx_albedo`].
pub fn dfg(alpha: f64, mu: f64, m: usize) -> (f64, f64) {
    let (mut sa, mut sb) = (0.0, 0.0);
    brdf::ggx_quadrature(alpha, mu, m, |w, vh| {
        let fc = (1.0 - vh).powi(5);
        sa += w * (1.0 - fc);
        sb += w * fc;
    });
    (sa, sb)
}

/// The N×N table (see the module's notes).
pub fn table(size: usize) -> Result<Image> {
    crate::base::limits::check_range(
        "size",
        size,
        crate::base::limits::DFG_MIN_SIZE,
        crate::base::limits::DFG_SIZE,
    )?;
    let mut img = Image::new(size, size, 3);
    img.data
        .par_chunks_mut(size * 3)
        .enumerate()
        .for_each(|(j, row)| {
            let r = (j as f64 + 0.5) / size as f64;
            for (i, px) in row.chunks_exact_mut(3).enumerate() {
                let mu = (i as f64 + 0.5) / size as f64;
                let (a, b) = dfg(r * r, mu, 64);
                px[0] = a as f32;
                px[1] = b as f32;
                px[2] = (a + b) as f32;
            }
        });
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plus_b_is_the_albedo() {
        for (alpha, mu) in [(0.04, 0.3), (0.5, 0.9), (1.0, 0.1)] {
            let (a, b) = dfg(alpha, mu, 96);
            let e = brdf::ggx_albedo(alpha, mu, 96);
            assert!((a + b - e).abs() < 1e-12, "{a} + {b} vs {e}");
            assert!(a > 0.0 && b >= 0.0 && b < a);
        }
    }
}
