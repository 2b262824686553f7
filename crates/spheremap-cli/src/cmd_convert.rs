//! `spheremap convert`: any environment mapping to any other.  The flags are a
//! [`ConvertJob`]; the core resolves and runs it (`spheremap::jobs::convert`).

use spheremap::jobs::convert::ConvertJob;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// IN OUT. IN: an image (EXR, HDR, PFM, PNG, JPEG, WebP, KTX2, DDS); OUT: an image, its
    /// format by extension (.exr .hdr .pfm .png .jpg .ktx2 .dds; a cube without --layout in
    /// .ktx2/.dds is a cube texture). A cube side may instead be six face files: named
    /// one by one in GL order (+X -X +Y -Y +Z -Z; so IN OUT is 7 or 12 paths), or a pattern:
    /// 'sky_{face}.exr' (px nx py ny pz nz), {posx} (posx negx ...), {side} (right left top
    /// bottom front back; front = +Z) or {index} (0-5).
    #[arg(required = true, num_args = 2..=12, value_names = ["IN", "OUT"])]
    paths: Vec<String>,
    #[command(flatten)]
    source: crate::source_args::SourceArgs,
    /// Output mapping (same names). Default: the input's mapping, preset, cube layout and
    /// view, so that `convert IN OUT` changes only the file format (the texels are copied).
    #[arg(long, value_parser = crate::names::core("mapping"))]
    to: Option<String>,
    /// Preset of the output mapping (default: the mapping's own; without --to, the input's).
    #[arg(long)]
    preset: Option<String>,
    /// Output size N: sphere/angular/octahedral N×N, latlong/paraboloid 2N×N, cube faces N×N.
    /// Default: the input's N (a cube face F gives 2F, and N gives cube faces of N/2).
    #[arg(long)]
    size: Option<usize>,
    #[command(flatten)]
    sampling: crate::sampling_args::SamplingArgs,
    #[command(flatten)]
    view: crate::view_args::ViewArgs,
    /// The output's view as yaw (degrees about world +Y; 90 = looking along -X).
    #[arg(long, allow_negative_numbers = true, conflicts_with = "look")]
    yaw: Option<f64>,
    /// Pitch in degrees (90 = looking up).
    #[arg(long, allow_negative_numbers = true, conflicts_with = "look")]
    pitch: Option<f64>,
    /// Roll in degrees (about the view axis, counter-clockwise as seen).
    #[arg(long, allow_negative_numbers = true, conflicts_with = "look")]
    roll: Option<f64>,
    /// Cube layout of the output: hcross (default), vcross, hstrip, vstrip, dice, horizon.
    #[arg(long, value_parser = crate::names::core("layout"))]
    layout: Option<String>,
    /// f32 (fast, default) or f64 (reference) arithmetic.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::resample::Precision>())]
    precision: spheremap::resample::Precision,
    /// How each sample reads the input's texels: bilinear (default: 2×2) or bicubic (4×4
    /// Catmull-Rom, clamped to the nearest 2×2's range: sharper where output texels are as
    /// small as the input's or smaller; slower).
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::resample::Taps>())]
    taps: spheremap::resample::Taps,
    /// Read/write LDR files as linear values (no sRGB transfer).
    #[arg(long)]
    linear: bool,
    /// Leave out the light-keeping step: by default (with --samples > 1) the input's
    /// brightest texels (a sun, a softbox) are integrated exactly over the output's texels and
    /// the sampled part normalized, so the output's power is the input's (see --json's
    /// "light"); with this flag the sampled filter alone decides.
    #[arg(long)]
    no_conserve: bool,
    #[command(flatten)]
    job: crate::job::JobFlags,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let job = ConvertJob {
        source: a.source.source(),
        to: a.to,
        preset: a.preset,
        layout: a.layout,
        size: a.size,
        look: a.view.get().0,
        up: a.view.get().1,
        yaw: a.yaw,
        pitch: a.pitch,
        roll: a.roll,
        samples: a.sampling.samples,
        max_samples: a.sampling.max_samples,
        filter: a.sampling.filter,
        taps: a.taps,
        outside: a.sampling.outside,
        seed: a.sampling.seed,
        precision: a.precision,
        conserve: !a.no_conserve,
        max_memory: Some(a.job.max_memory()?),
        nonfinite: a.job.nonfinite,
        linear: a.linear,
        png16: a.job.png16,
        half: a.job.half,
        clamp_half: a.job.clamp_half,
        encode: a.job.encoding(),
        zstd: a.job.zstd,
        force: a.job.force,
    };
    let report = crate::progress::run(a.job.show_progress(), "converting", |p| {
        job.run_files(&a.paths, Some(p))
    })
    .map_err(crate::flag_error)?;
    if let (Some(n), false) = (&report.notice, a.job.quiet) {
        eprintln!("note: {n}");
    }
    let words = crate::Words::Stderr { quiet: a.job.quiet };
    crate::print_report(&report, a.job.json, words);
    Ok(())
}
