//! # spheremap
//!
//! Exact, documented and fast sphere-map environment mapping: OpenGL `GL_SPHERE_MAP` texgen,
//! mirror-ball images and MatCaps.
//!
//! * [`conventions`] — **read first**: eye space, the disc, image rows vs t, texel centres,
//!   presets for other tools.
//! * [`sphere`] — direction ↔ (s,t), reflection, exact texel solid angles.
//! * [`texgen`] — mesh texgen exactly as OpenGL computes it (f32 fast path, f64 reference).
//! * [`latlong`] — the lat-long (equirectangular) mapping and its presets (Blender, three.js, skylibs, Filament, Mitsuba, pbrt).
//! * [`matcap`] — MatCap lookups (classic, three.js, perspective-correct).
//! * [`image_io`] — images in and out (EXR, HDR, PFM, PNG, JPEG, WebP), by content.
//! * [`mesh`], [`io`], [`parse`] — meshes in, vertex data out, small textual inputs.
//! * [`chart`], [`demo`] — the labelled direction chart and the built-in demo.

// `!(x > 0)` and friends are deliberate throughout: they send NaN down the invalid branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Index loops over channels and axes read like the formulas they implement.
#![allow(clippy::needless_range_loop)]

pub mod analyze;
pub mod angular;
pub mod buffer;
pub mod camera;
pub mod chart;
pub mod conventions;
pub mod cube;
pub mod demo;
pub mod draw;
pub mod envio;
pub mod error;
pub mod fisheye;
pub mod generate;
pub mod image_io;
pub mod io;
pub mod latlong;
pub mod mapping;
pub mod matcap;
pub mod mesh;
pub mod octahedral;
pub mod paraboloid;
pub mod parse;
pub mod photo;
mod quad;
pub mod real;
pub mod render;
pub mod resample;
pub mod scene;
pub mod shader;
pub mod sphere;
pub mod tag;
pub mod texgen;
pub mod tonemap;
pub mod view;

pub use conventions::{RowOrder, Singular, SpherePreset, PRESETS};
pub use error::{Error, Result};
pub use mapping::Mapping;
pub use matcap::{matcap_uv, MatcapVariant};
pub use sphere::{dir_to_st, reflect, st_to_dir, texel_solid_angle};
pub use texgen::{sphere_texgen, sphere_texgen_f64, ModelviewState, NormalMode, TexgenOptions};

/// The crate version.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
