//! Layer 7, jobs: what a user asks for, each operation one request — the environment a job
//! reads, spelled once ([`source`]), conversions ([`convert`]), MatCap bakes
//! ([`bake_matcap`]), prefiltered chains ([`prefilter`]) and irradiance ([`irradiance`]) over the
//! maths of [`crate::lighting`], environment maps from photos ([`photo`]), GL-exact renders of
//! meshes ([`render`]), analytics and figures ([`analyze`], [`chart`]) and shader snippets
//! ([`shader`]).

pub mod analyze;
pub mod bake_matcap;
pub mod chart;
pub mod convert;
pub mod irradiance;
#[cfg(feature = "photo")]
pub mod photo;
pub mod prefilter;
pub mod render;
pub mod shader;
pub mod source;
