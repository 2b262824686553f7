//! Layer 7, jobs: what a user asks for, each operation one request — the environment a job
//! reads, spelled once ([`source`]), conversions ([`convert`]), MatCap bakes
//! ([`bake_matcap`]), prefiltered chains ([`prefilter`]), irradiance ([`irradiance`]) and the DFG
//! table ([`dfg`]) over the
//! maths of [`crate::lighting`], environment maps from photos ([`photo`]), GL-exact renders of
//! meshes ([`render`]), analytics and figures ([`analyze`], [`chart`]) and shader snippets
//! ([`shader`]).

pub mod analyze;
pub mod bake_matcap;
pub mod chart;
pub mod convert;
pub mod dfg;
pub mod irradiance;
#[cfg(feature = "photo")]
pub mod photo;
pub mod prefilter;
pub mod render;
pub mod shader;
pub mod source;

/// Every request's documented defaults, by operation (`convert`, `bake-matcap`, `prefilter`,
/// `irradiance`, `dfg`, `render`, `generate`), as JSON: what each `Default` holds.  The CLI's flags
/// take their defaults from the requests; Python's signatures are checked against these.
pub fn defaults(op: &str) -> Option<serde_json::Value> {
    fn json<T: serde::Serialize>(t: T) -> Option<serde_json::Value> {
        serde_json::to_value(t).ok()
    }
    match op {
        "convert" => json(convert::ConvertJob::default()),
        "bake-matcap" => json(bake_matcap::MatcapRequest::default()),
        "prefilter" => json(prefilter::PrefilterRequest::default()),
        "irradiance" => json(irradiance::IrradianceRequest::default()),
        "dfg" => json(dfg::DfgRequest::default()),
        "render" => json(render::RenderRequest::default()),
        "generate" => json(crate::trace::generate::MapRequest::default()),
        _ => None,
    }
}
