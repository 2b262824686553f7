//! # spheremap
//!
//! Exact, documented and fast sphere-map environment mapping: OpenGL `GL_SPHERE_MAP` texgen,
//! mirror-ball images and MatCaps, conversions between mappings, ray-traced maps, maps from
//! photos, GL-exact renders and analytics.
//!
//! The crate is a stack of layers; a module uses its own layer and those below, never one above
//! (checked by `tests/layers.rs`; the diagram and the map of concepts are in `ARCHITECTURE.md`):
//!
//! | layer | modules |
//! |---|---|
//! | 7 top | [`demo`], [`names`] (every list of names and its parser) |
//! | 6 jobs, lighting | [`jobs`]: convert, photo, render, analyze, chart, shader; [`lighting`]: materials, MatCap bakes, spherical harmonics, the DFG table |
//! | 5 tracing | [`trace`]: generate, scene, camera |
//! | 4 resampling | [`resample`]: filters, strata, the CPU dispatch, conversions |
//! | 3 images and meshes | [`images`]: the `Image` type, codecs, the map note, cube layouts, environment files; [`mesh`] |
//! | 2 mappings | [`mappings`]: sphere, latlong, cube, angular, paraboloid, octahedral, fisheye, texgen, matcap |
//! | 1 frames | [`frame`]: conventions (**read first**), views |
//! | 0 base | [`base`]: errors, `Real`, quadrature, files, parsing, buffers |

// `!(x > 0)` and friends are deliberate throughout: they send NaN down the invalid branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Index loops over channels and axes read like the formulas they implement.
#![allow(clippy::needless_range_loop)]

pub mod base;
pub mod batch;
#[cfg(feature = "scene")]
pub mod demo;
pub mod frame;
pub mod images;
pub mod jobs;
pub mod lighting;
pub mod mappings;
pub mod mesh;
pub mod names;
pub mod resample;
pub mod trace;
#[cfg(feature = "scene")]
pub mod view;

pub use base::error::{Error, Result};
pub use frame::conventions::{RowOrder, Singular, SpherePreset, PRESETS};
pub use mappings::mapping::Mapping;
pub use mappings::matcap::{matcap_uv, MatcapVariant};
pub use mappings::sphere::{dir_to_st, reflect, st_to_dir, texel_solid_angle};
pub use mappings::texgen::{
    sphere_texgen, sphere_texgen_f64, ModelviewState, NormalMode, TexgenOptions,
};

/// The crate version.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
