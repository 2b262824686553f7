//! `spheremap generate`: sphere maps (or any mapping) by ray tracing a scene, or by firing rays
//! into an environment map: its flags as the core's `MapRequest` and `jobs::scene::SceneRequest`,
//! run (`SceneRequest::generate_files`) and reported.

use crate::job::vec3;
use spheremap::images::envmap::env_paths;
use spheremap::trace::generate::MapRequest;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    world: crate::scene_args::SceneArgs,
    /// The point the rays start from (world coordinates).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pos: Option<Vec<f32>>,
    #[command(flatten)]
    view: crate::view_args::ViewArgs,
    /// Output mapping (default sphere: the GL sphere map of the view).
    #[arg(long, default_value_t = MapRequest::default().to, value_parser = crate::names::core("mapping"))]
    to: String,
    /// Preset of the output mapping.
    #[arg(long)]
    preset: Option<String>,
    /// Cube layout of the output when --to cube.
    #[arg(long, value_parser = crate::names::core("layout"))]
    layout: Option<String>,
    /// Output size N (sphere N×N; latlong 2N×N; cube faces N×N).
    #[arg(long, default_value_t = MapRequest::default().size)]
    size: usize,
    #[command(flatten)]
    sampling: crate::sampling_args::SamplingArgs,
    /// f32 (default) or f64 arithmetic for the ray directions.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::resample::Precision>())]
    precision: spheremap::resample::Precision,
    /// Also ray-trace the six cube faces at --pos into this folder (px nx py ny pz nz .exr):
    /// the first step of the two-step route (then `spheremap convert 'DIR/{face}.exr' ...`).
    #[arg(long)]
    faces_out: Option<PathBuf>,
    /// Face size for --faces-out (default: --size).
    #[arg(long)]
    faces_size: Option<usize>,
    /// Output file (.exr .hdr .pfm .png .jpg), or a {face} pattern with --to cube.
    #[arg(short = 'o', long)]
    output: String,
    #[command(flatten)]
    job: crate::job::JobFlags,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let request = MapRequest {
        to: a.to.clone(),
        preset: a.preset.clone(),
        layout: a.layout.clone(),
        size: a.size,
        pos: vec3(&a.pos).unwrap_or([0.0; 3]),
        look: a.view.get().0,
        up: a.view.get().1,
        samples: a.sampling.samples,
        max_samples: a.sampling.max_samples,
        filter: a.sampling.filter,
        outside: a.sampling.outside,
        seed: a.sampling.seed,
        precision: a.precision,
        max_memory: Some(a.job.max_memory()?),
    };
    request.resolve().map_err(crate::flag_error)?;
    a.world.refuse_overwrite(&a.job, &env_paths(&a.output))?;
    let scene = a.world.request(a.job.nonfinite()?, a.sampling.seed);
    let wopts = a.job.write_options(false);
    let faces = a.faces_out.as_deref().map(|d| (d, a.faces_size));
    let report = crate::progress::run(a.job.show_progress(), "ray tracing", |p| {
        scene.generate_files(
            &request,
            a.world.env.as_deref(),
            &a.output,
            faces,
            &wopts,
            Some(p),
        )
    })
    .map_err(|e| crate::scene_args::flag_error(e.renamed("faces_size", "faces-size")))?;
    let words = crate::Words::Stderr { quiet: a.job.quiet };
    crate::print_report(&report, a.job.json, words);
    Ok(())
}
