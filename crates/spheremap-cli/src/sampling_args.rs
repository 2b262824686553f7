//! The filtering flags of every command that fills texels from samples — `convert`,
//! `generate`, `from-photo`, `from-fisheye`: one place for their names, defaults and help.

use spheremap::resample::DEFAULT_SAMPLES;

#[derive(clap::Args, Debug)]
pub struct SamplingArgs {
    /// Samples per output texel (rays, for `generate`): 1 = one at the texel centre (no
    /// filtering, for comparisons); S > 1 = at least S, more where a texel's footprint is
    /// stretched or covers more source texels.
    #[arg(long, default_value_t = DEFAULT_SAMPLES)]
    pub samples: u32,
    /// The most samples one texel may take when adapting to its footprint (conversions: beyond
    /// it, the lookups read prefiltered source levels).
    #[arg(long, default_value_t = spheremap::jobs::convert::ConvertJob::default().max_samples)]
    pub max_samples: u32,
    /// Reconstruction filter: box (the texel's own footprint, default), tent, gaussian.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::resample::Filter>())]
    pub filter: spheremap::resample::Filter,
    /// Outside a sphere/angular/paraboloid disc: gutter (mirror across the rim, no dark fringe
    /// under GPU filtering; default) or black.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::resample::Outside>())]
    pub outside: spheremap::resample::Outside,
    /// Seed of the sample jitter (results are deterministic for a seed).
    #[arg(long, default_value_t = spheremap::jobs::convert::ConvertJob::default().seed)]
    pub seed: u64,
}
