//! Layer 6, jobs: what a user asks for on top of maps — conversions as one request
//! ([`convert`]), environment maps from photos
//! ([`photo`]), GL-exact renders of meshes ([`render`]), analytics and figures ([`analyze`],
//! [`chart`]) and shader snippets ([`shader`]).

pub mod analyze;
pub mod chart;
pub mod convert;
#[cfg(feature = "photo")]
pub mod photo;
pub mod render;
pub mod shader;
