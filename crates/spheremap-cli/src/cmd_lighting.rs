//! `spheremap bake-matcap`, `prefilter`, `irradiance` and `dfg`: lighting from a map (thin layer over
//! the core's requests, `spheremap::jobs::{bake_matcap, prefilter, irradiance, dfg}`).

use crate::job::vec3;
use spheremap::jobs::bake_matcap::MatcapRequest;
use spheremap::jobs::dfg::DfgRequest;
use spheremap::jobs::env_job::EnvJob;
use spheremap::jobs::irradiance::IrradianceRequest;
use spheremap::jobs::prefilter::PrefilterRequest;
use spheremap::lighting::sh;

/// The environment a lighting command reads.
#[derive(clap::Args, Debug)]
pub struct EnvArgs {
    /// The environment map: an image (EXR, HDR, PFM, PNG, JPEG, WebP, KTX2, DDS) or six cube
    /// faces as a pattern ('sky_{face}.exr').
    env: String,
    #[command(flatten)]
    source: crate::source_args::SourceArgs,
}

#[derive(clap::Args, Debug)]
pub struct BakeArgs {
    #[command(flatten)]
    env: EnvArgs,
    /// The material: lambert (albedo/π) or ggx (GGX, height-correlated Smith, Fresnel 1).
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::lighting::brdf::MaterialName>())]
    material: spheremap::lighting::brdf::MaterialName,
    /// GGX perceptual roughness 0..1 (α = roughness², as glTF, Blender and Filament); 0 is the
    /// mirror (the sphere map of the view).
    #[arg(long, default_value_t = MatcapRequest::default().roughness)]
    roughness: f64,
    /// Linear RGB albedo (default 0.8 0.8 0.8 for lambert, 1 1 1 for ggx).
    #[arg(long, num_args = 3, value_names = ["R", "G", "B"], allow_negative_numbers = true)]
    albedo: Option<Vec<f64>>,
    #[command(flatten)]
    view: crate::view_args::ViewArgs,
    /// Output size N (N×N).
    #[arg(long, default_value_t = MatcapRequest::default().size)]
    size: usize,
    /// Spatial samples per texel (1: the texel centre; S > 1: at least S, more at the rim).
    #[arg(long, default_value_t = spheremap::resample::DEFAULT_SAMPLES)]
    samples: u32,
    /// The most samples a rim texel may take.
    #[arg(long, default_value_t = MatcapRequest::default().max_samples)]
    max_samples: u32,
    /// Seed of the sample jitter.
    #[arg(long, default_value_t = MatcapRequest::default().seed)]
    seed: u64,
    /// Outside the disc: gutter (default) or black.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::resample::Outside>())]
    outside: spheremap::resample::Outside,
    /// Output file (.exr .hdr .pfm .png .jpg).
    #[arg(short = 'o', long)]
    output: String,
    #[command(flatten)]
    job: crate::job::JobFlags,
}

pub fn run_bake(a: BakeArgs) -> anyhow::Result<()> {
    let request = MatcapRequest {
        material: a.material,
        roughness: a.roughness,
        albedo: vec3(&a.albedo),
        size: a.size,
        look: a.view.get().0,
        up: a.view.get().1,
        samples: a.samples,
        max_samples: a.max_samples,
        seed: a.seed,
        outside: a.outside,
        source: a.env.source.source(),
        nonfinite: a.job.nonfinite,
        max_memory: Some(a.job.max_memory()?),
    };
    let wopts = a.job.write_options(false);
    let (report, notice) = crate::progress::run(a.job.show_progress(), "baking", |p| {
        request.run_files(&a.env.env, &a.output, &wopts, a.job.force, Some(p))
    })
    .map_err(crate::flag_error)?;
    if let Some(n) = notice.filter(|_| !a.job.quiet) {
        eprintln!("note: {n}");
    }
    let words = crate::Words::Stderr { quiet: a.job.quiet };
    crate::print_report(&report, a.job.json, words);
    Ok(())
}

#[derive(clap::Args, Debug)]
pub struct IrradianceArgs {
    #[command(flatten)]
    env: EnvArgs,
    /// Filament's ringing window: a size in bands (the band-l factor is (sin x / x)^4,
    /// x = pi l / W), or auto (the largest that leaves no negative irradiance).
    #[arg(long, allow_hyphen_values = true)]
    window: Option<String>,
    /// Print the report as JSON on stdout (three.js and Filament coefficients).
    #[arg(long)]
    json: bool,
    /// Also write Filament's sh.txt (pre-scaled for its shader) here.
    #[arg(long)]
    sh_txt: Option<String>,
    /// Also write here the irradiance map (an image, or six faces as a '{face}' pattern: the
    /// full integral, no SH truncation), or the report (.json).
    #[arg(short = 'o', long)]
    output: Option<String>,
    /// Mapping of the irradiance map.
    #[arg(long, default_value_t = IrradianceRequest::default().to, value_parser = crate::names::core("mapping"))]
    to: String,
    /// Cube layout of the irradiance map when --to cube.
    #[arg(long, value_parser = crate::names::core("layout"))]
    layout: Option<String>,
    /// Size N of the irradiance map (cube faces N×N; latlong 2N×N).
    #[arg(long, default_value_t = IrradianceRequest::default().size)]
    size: usize,
    /// Samples per texel of the irradiance map.
    #[arg(long, default_value_t = IrradianceRequest::default().samples)]
    samples: u32,
    /// NaN/Inf in the map: error (default), zero or keep.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::images::codec::NonFinite>())]
    nonfinite: spheremap::images::codec::NonFinite,
    /// Allow an output to overwrite the input.
    #[arg(long)]
    force: bool,
    /// No summary on stderr.
    #[arg(short, long)]
    quiet: bool,
}

pub fn run_irradiance(a: IrradianceArgs) -> anyhow::Result<()> {
    let window = a
        .window
        .as_deref()
        .map(str::parse::<sh::Window>)
        .transpose()
        .map_err(crate::flag_error)?
        .unwrap_or_default();
    let request = IrradianceRequest {
        source: a.env.source.source(),
        nonfinite: a.nonfinite,
        window,
        to: a.to.clone(),
        layout: a.layout.clone(),
        size: a.size,
        samples: a.samples,
    };
    let outputs: Vec<String> = a.sh_txt.iter().chain(&a.output).cloned().collect();
    let (report, notice) = request
        .run_files(&a.env.env, &outputs, &Default::default(), a.force)
        .map_err(crate::flag_error)?;
    if let (Some(n), false) = (&notice, a.quiet) {
        eprintln!("note: {n}");
    }
    crate::print_report(&report, a.json, crate::Words::Stderr { quiet: a.quiet });
    Ok(())
}

#[derive(clap::Args, Debug)]
pub struct DfgArgs {
    /// Table size N (N×N): column i is n·v = (i+½)/N, row j (row 0 first) roughness (j+½)/N.
    #[arg(long, default_value_t = DfgRequest::default().size)]
    size: usize,
    /// Output file (.exr .pfm .hdr; channels A, B, A+B).
    #[arg(short = 'o', long)]
    output: String,
    #[command(flatten)]
    job: crate::job::JobFlags,
}

pub fn run_dfg(a: DfgArgs) -> anyhow::Result<()> {
    let request = DfgRequest { size: a.size };
    let report = request
        .run_files(&a.output, &a.job.write_options(true))
        .map_err(crate::flag_error)?;
    let words = crate::Words::Stderr { quiet: a.job.quiet };
    crate::print_report(&report, a.job.json, words);
    Ok(())
}

#[derive(clap::Args, Debug)]
pub struct PrefilterArgs {
    #[command(flatten)]
    env: EnvArgs,
    /// Output mapping: cube (default), octahedral, latlong, sphere (the exact prefiltered sphere
    /// map of the view: the GGX MatCap of each level's roughness), or any other.
    #[arg(long, default_value_t = PrefilterRequest::default().to, value_parser = crate::names::core("mapping"))]
    to: String,
    /// Preset of the output mapping.
    #[arg(long)]
    preset: Option<String>,
    /// Cube layout of levels written as images ('{level}' in -o); a .ktx2/.dds cube holds faces.
    #[arg(long, value_parser = crate::names::core("layout"))]
    layout: Option<String>,
    /// Level 0's size N (cube faces NxN, latlong 2NxN); default 256, 32 with --irradiance.
    #[arg(long)]
    size: Option<usize>,
    /// Mip levels, each half the last; default down to 8 texels (6 for 256).
    #[arg(long)]
    levels: Option<usize>,
    /// Level -> roughness: filament (r(2-r) = level/(L-1); also three.js from r187),
    /// threejs (three.js up to r186: its cube-UV PMREM's roughnessToMip at log2 of the
    /// level's size) or linear.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::lighting::prefilter::RoughnessMap>())]
    roughness_map: spheremap::lighting::prefilter::RoughnessMap,
    /// One level of the cosine-convolved map ((1/pi) times the irradiance) instead.
    #[arg(long)]
    irradiance: bool,
    #[command(flatten)]
    view: crate::view_args::ViewArgs,
    /// Spatial samples per texel (1, the default: the texel centre; S > 1: at least S over
    /// the texel's footprint, adaptive). A texel wider than its level's lobe holds the lobe's
    /// mean over its footprint either way (evaluated on a finer canvas).
    #[arg(long, default_value_t = PrefilterRequest::default().samples)]
    samples: u32,
    /// The most samples a texel may take.
    #[arg(long, default_value_t = PrefilterRequest::default().max_samples)]
    max_samples: u32,
    /// Seed of the sample jitter.
    #[arg(long, default_value_t = PrefilterRequest::default().seed)]
    seed: u64,
    /// Outside a sphere map's disc: gutter (default) or black.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::resample::Outside>())]
    outside: spheremap::resample::Outside,
    /// The error each integral may leave, relative to the map's mean radiance (default 1e-4;
    /// 1e-5 is three times slower, 1e-3 three times faster; with --irradiance, 2e-3 or more
    /// sums the map on a coarser cube, about twice as fast, and under 5e-5 on a finer one).
    #[arg(long)]
    tolerance: Option<f64>,
    /// tree: exact integrals on the environment's tree (default; with --irradiance, the cosine
    /// integral by the map's moments); sampled: filtered importance sampling from a cube mip
    /// pyramid, as Filament's cmgen (fast, approximate).
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::lighting::prefilter::PrefilterMethod>())]
    method: spheremap::lighting::prefilter::PrefilterMethod,
    /// GGX samples per texel with --method sampled (Filament's default).
    #[arg(long, default_value_t = PrefilterRequest::default().lobe_samples)]
    lobe_samples: usize,
    /// Output: a .ktx2 or .dds file (every level; a cube's six faces), or images with
    /// '{level}' in the name (.exr .hdr .pfm .png .jpg; '{face}' for cube face files).
    #[arg(short = 'o', long)]
    output: String,
    #[command(flatten)]
    job: crate::job::JobFlags,
}

pub fn run_prefilter(a: PrefilterArgs) -> anyhow::Result<()> {
    let request = PrefilterRequest {
        to: a.to.clone(),
        preset: a.preset.clone(),
        layout: a.layout.clone(),
        size: a.size,
        levels: a.levels,
        roughness_map: a.roughness_map,
        irradiance: a.irradiance,
        look: a.view.get().0,
        up: a.view.get().1,
        samples: a.samples,
        max_samples: a.max_samples,
        seed: a.seed,
        outside: a.outside,
        tolerance: a.tolerance,
        method: a.method,
        lobe_samples: a.lobe_samples,
        source: a.env.source.source(),
        nonfinite: a.job.nonfinite,
        max_memory: Some(a.job.max_memory()?),
    };
    let wopts = a.job.write_options(false);
    let (report, notice) = crate::progress::run(a.job.show_progress(), "prefiltering", |p| {
        request.run_files(&a.env.env, &a.output, &wopts, a.job.force, Some(p))
    })
    .map_err(crate::flag_error)?;
    if let Some(n) = notice.filter(|_| !a.job.quiet) {
        eprintln!("note: {n}");
    }
    let words = crate::Words::Stderr { quiet: a.job.quiet };
    crate::print_report(&report, a.job.json, words);
    Ok(())
}
