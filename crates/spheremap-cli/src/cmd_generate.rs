//! `spheremap generate`: sphere maps (or any mapping) by ray tracing a scene, or by firing rays
//! into an environment map (thin layer over `spheremap::trace::generate` and `spheremap::trace::scene`).

use crate::job::vec3;
use anyhow::Context;
use spheremap::images::envmap::{env_paths, write_env, EnvFiles};
use spheremap::images::Image;
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::IDENTITY;
use spheremap::trace::generate::{
    generate, GenerateOptions, GenerateReport, MapRequest, RaySource,
};
use spheremap::trace::scene::Scene;
use std::path::PathBuf;
use std::time::Instant;

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
    let map = request.resolve().map_err(crate::flag_error)?;
    let (dst, layout, opts) = (map.mapping, map.layout, map.options);
    EnvFiles::parse(&a.output).check_output(dst)?;
    let world = a
        .world
        .load(&a.job, a.sampling.seed, &env_paths(&a.output))?;
    let source = world.source();
    let source = source.as_ref();
    let scene = world.scene.as_ref();
    let wopts = a.job.write_options(false);
    let show = a.job.show_progress();
    let t0 = Instant::now();
    let (w, h) = (map.width, map.height);
    let (out, report) = run_generate(dst, w, h, source, &opts, show, "ray tracing")?;
    let seconds = t0.elapsed().as_secs_f64();
    let mut written = write_env(&a.output, dst, &out, layout, &map.view, &wopts)?;
    if let Some(dir) = &a.faces_out {
        // The cube faces are made in the world frame (no view), as six cameras at `pos` would take them.
        let cube = Mapping::parse("cube", None)?;
        let f = a.faces_size.unwrap_or(a.size);
        spheremap::base::limits::check_map_size("faces-size", f)?;
        std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
        let fo = GenerateOptions {
            rotation: IDENTITY,
            ..opts
        };
        let (faces, _) = run_generate(cube, f, 6 * f, source, &fo, show, "cube faces")?;
        let pattern = dir.join("{face}.exr").display().to_string();
        written.extend(write_env(&pattern, cube, &faces, None, &IDENTITY, &wopts)?);
    }
    summary(&a, dst, &out, &report, seconds, &written, scene)
}

fn run_generate(
    m: Mapping,
    w: usize,
    h: usize,
    source: &dyn RaySource,
    opts: &GenerateOptions,
    show: bool,
    what: &str,
) -> anyhow::Result<(Image, GenerateReport)> {
    Ok(crate::progress::run(show, what, |p| {
        generate(m, w, h, source, opts, Some(p))
    })?)
}

#[allow(clippy::too_many_arguments)]
fn summary(
    a: &Args,
    dst: Mapping,
    out: &Image,
    r: &GenerateReport,
    seconds: f64,
    written: &[String],
    scene: Option<&Scene>,
) -> anyhow::Result<()> {
    let rays_per_texel = r.rays as f64 / r.texels.max(1) as f64;
    let (w, h) = (out.width, out.height);
    let losses = a.job.losses(out, &written[0], false);
    let report = spheremap::trace::generate::GenerateSummary {
        scene: a.world.scene.clone(),
        env: a.world.env.clone(),
        output: written.to_vec(),
        to: dst.name(),
        preset: dst.preset_name(),
        size: a.size,
        width: w,
        height: h,
        samples: a.sampling.samples,
        filter: a.sampling.filter.name(),
        outside: a.sampling.outside.name(),
        triangles: scene.map(|s| s.triangle_count()),
        degenerate_triangles: scene.map(|s| s.degenerate_count()),
        lights: scene.map(|s| s.lights.len()),
        rays: r.rays,
        texels_traced: r.texels,
        rays_per_texel,
        max_texel_samples: r.max_texel_samples,
        seconds,
        rays_per_second: r.rays as f64 / seconds.max(1e-9),
        clipped: losses.clipped,
        clamped_half: losses.beyond_half,
    };
    let words = crate::Words::Stderr { quiet: a.job.quiet };
    crate::print_report(&report, a.job.json, words);
    Ok(())
}
