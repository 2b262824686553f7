//! Layer 7, jobs: what a user asks for, each operation one request — the environment a job
//! reads, spelled once ([`source`]), conversions ([`convert`]), MatCap bakes ([`bake_matcap`]),
//! prefiltered chains ([`prefilter`]), irradiance ([`irradiance`]) and the DFG table ([`dfg`])
//! over the maths of [`crate::lighting`], environment maps from photos ([`photo`]), GL-exact
//! renders of meshes ([`render`]), what rays see ([`scene`]), a file's description ([`info`]), GL's sphere-map texgen of a mesh ([`texgen`]), analytics and figures ([`analyze`], [`chart`]) and shader
//! snippets ([`shader`]); every request's defaults by operation ([`defaults`]), a request read from its fields with errors
//! that name them ([`fields`]) and the run the
//! bake and the prefilter share ([`env_job`]).

pub mod analyze;
pub mod bake_matcap;
pub mod chart;
pub mod convert;
pub mod defaults;
pub mod dfg;
pub mod env_job;
pub mod fields;
pub mod info;
pub mod irradiance;
#[cfg(feature = "photo")]
pub mod photo;
pub mod prefilter;
pub mod render;
#[cfg(feature = "scene")]
pub mod scene;
pub mod shader;
pub mod source;
pub mod texgen;

/// A report of an operation: JSON by its serde fields (`--json`, Python's dicts) and, for the
/// CLI's output without `--json`, in words.
pub trait Report: serde::Serialize {
    /// The report in words, a line each.
    fn lines(&self) -> Vec<String>;
}
