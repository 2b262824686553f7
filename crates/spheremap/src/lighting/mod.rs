//! Layer 6, lighting: what a map does to a material lit by it — the maths only.  The requests
//! that run it on files and arrays ([`crate::jobs::bake_matcap`], [`crate::jobs::prefilter`],
//! [`crate::jobs::irradiance`]) are one layer up, with the conversions.
//!
//! * [`brdf`]: the materials (Lambert, GGX with height-correlated Smith G₂ and Fresnel 1),
//!   their directional albedo, the visible-normal sampler;
//! * [`envtree`]: the environment as a tree of cube texel blocks, for exact lobe integrals;
//! * [`cosine`]: the cosine (irradiance) integral, exact where the horizon does not cross, and
//!   [`irradiance_map`];
//! * [`matcap`]: physically exact MatCaps (the lit sphere of a material seen by an
//!   orthographic viewer);
//! * [`prefilter`]: the GGX radiance mip chain and the irradiance map engines load;
//! * [`sh`]: order-2 spherical harmonics of a map and the irradiance they imply, in the
//!   conventions of three.js and Filament;
//! * [`dfg`]: the split-sum DFG lookup table of the same GGX.

pub mod brdf;
pub mod cosine;
pub mod dfg;
pub mod envtree;
pub mod matcap;
pub mod prefilter;
pub mod sh;

use crate::base::error::Result;
use crate::images::Image;
use crate::resample::EnvMap;

/// The irradiance map of `env` (E(n) = ∫ L(l) max(0, n·l) dω, the full integral
/// ([`cosine`], within 1e-4 of π L̄ of the brute-force sum), no spherical-harmonics truncation)
/// as a `width`×`height` canvas of `mapping` in the world frame, `samples` normals per texel.
pub fn irradiance_map(
    env: &EnvMap,
    world_to_env: &crate::frame::view::Mat3,
    mapping: crate::mappings::mapping::Mapping,
    width: usize,
    height: usize,
    samples: u32,
) -> Result<Image> {
    let tree = cosine::CosineTree::build(env, *world_to_env, cosine::DEFAULT_FACE)?;
    let source = cosine::CosineSource {
        tree: &tree,
        normal: |d| d,
        scale: [1.0; 3],
        channels: tree.channels,
    };
    let opts = crate::trace::generate::GenerateOptions {
        samples,
        ..Default::default()
    };
    let (img, _) = source.generate(mapping, width, height, &opts, None)?;
    Ok(img)
}
