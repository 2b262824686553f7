//! Every request's documented defaults, by operation: what the CLI's flags show and Python's
//! signatures are held to.

use crate::jobs::{analyze, bake_matcap, convert, dfg, irradiance, prefilter, render};

/// The defaults of the request of `op` (`convert`, `bake-matcap`, `prefilter`, `irradiance`,
/// `dfg`, `render`, `analyze`, `info`, `texgen`, `generate`, `preview`, `from-photo`, `from-fisheye`) as JSON: what its `Default` holds.  The CLI's flags take their
/// defaults from the requests; Python's signatures are checked against these.
pub fn of(op: &str) -> Option<serde_json::Value> {
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
        "analyze" => json(analyze::AnalyzeRequest::default()),
        "info" => json(super::info::InfoRequest::default()),
        "texgen" => json(super::texgen::TexgenRequest::default()),
        "generate" => json(crate::trace::generate::MapRequest::default()),
        "preview" => json(crate::trace::camera::PreviewRequest::default()),
        #[cfg(feature = "photo")]
        "from-photo" => json(super::photo::BallRequest::default()),
        #[cfg(feature = "photo")]
        "from-fisheye" => json(super::photo::FisheyeRequest::default()),
        _ => None,
    }
}
