//! `spheremap convert`: any environment mapping to any other (thin layer over
//! `spheremap::resample` and `spheremap::images::envmap`).

use crate::job::vec3;
use anyhow::{bail, Context};
use spheremap::frame::view;
use spheremap::images::codec::ReadOptions;
use spheremap::images::cube_layout::Layout;
use spheremap::images::envmap::{
    check_nonfinite_env, default_size, layout_for, mapping_for, read_env_layout, read_note,
    split_paths, write_env_files, EnvFiles,
};
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::{resample, EnvMap, Precision, Progress, ResampleOptions, Taps};
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// IN OUT. IN: an image (EXR, HDR, PFM, PNG, JPEG, WebP); OUT: an image, its format by
    /// extension (.exr .hdr .pfm .png .jpg). A cube side may instead be six face files: named
    /// one by one in GL order (+X -X +Y -Y +Z -Z; so IN OUT is 7 or 12 paths), or a pattern:
    /// 'sky_{face}.exr' (px nx py ny pz nz), {posx} (posx negx ...), {side} (right left top
    /// bottom front back; front = +Z) or {index} (0-5).
    #[arg(required = true, num_args = 2..=12, value_names = ["IN", "OUT"])]
    paths: Vec<String>,
    /// Input mapping: sphere, latlong, cube, angular, paraboloid, octahedral. Default: the
    /// mapping (and preset, and cube layout) that spheremap recorded in IN when it wrote it.
    #[arg(long)]
    from: Option<String>,
    /// Output mapping (same names). Default: the input's mapping, preset, cube layout and
    /// view, so that `convert IN OUT` changes only the file format (the texels are copied).
    #[arg(long)]
    to: Option<String>,
    /// Preset of the input mapping (see `spheremap conventions`); default: the mapping's own.
    #[arg(long)]
    from_preset: Option<String>,
    /// Preset of the output mapping (default: the mapping's own; without --to, the input's).
    #[arg(long)]
    preset: Option<String>,
    /// Output size N: sphere/angular/octahedral N×N, latlong/paraboloid 2N×N, cube faces N×N.
    /// Default: the input's N (a cube face F gives 2F, and N gives cube faces of N/2).
    #[arg(long)]
    size: Option<usize>,
    #[command(flatten)]
    sampling: crate::sampling_args::SamplingArgs,
    /// The output's view: world direction of the eye's -Z (with --up).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    look: Option<Vec<f64>>,
    /// The output's view: world direction of the eye's +Y (with --look; default 0 1 0).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    up: Option<Vec<f64>>,
    /// The output's view as yaw (degrees about world +Y; 90 = looking along -X).
    #[arg(long, allow_negative_numbers = true, conflicts_with = "look")]
    yaw: Option<f64>,
    /// Pitch in degrees (90 = looking up).
    #[arg(long, allow_negative_numbers = true, conflicts_with = "look")]
    pitch: Option<f64>,
    /// Roll in degrees (about the view axis, counter-clockwise as seen).
    #[arg(long, allow_negative_numbers = true, conflicts_with = "look")]
    roll: Option<f64>,
    /// The input's view, when it was made for one (a sphere map of a turned camera).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    from_look: Option<Vec<f64>>,
    /// The input view's up (with --from-look).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    from_up: Option<Vec<f64>>,
    /// Cube layout of the output: hcross (default), vcross, hstrip, vstrip, dice, horizon.
    #[arg(long)]
    layout: Option<String>,
    /// Cube layout of the input (default: from its shape; a 6:1 strip must be named).
    #[arg(long)]
    from_layout: Option<String>,
    /// f32 (fast, default) or f64 (reference) arithmetic.
    #[arg(long, default_value = "f32")]
    precision: String,
    /// How each sample reads the input's texels: bilinear (default: 2×2) or bicubic (4×4
    /// Catmull-Rom, clamped to the nearest 2×2's range: sharper where output texels are as
    /// small as the input's or smaller; slower).
    #[arg(long, default_value = "bilinear")]
    taps: String,
    /// Read/write LDR files as linear values (no sRGB transfer).
    #[arg(long)]
    linear: bool,
    #[command(flatten)]
    job: crate::job::JobFlags,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    // What IN records (spheremap's note, crate::images::note): the default of --from, --from-preset,
    // --from-layout and --from-look/--from-up, and a check on --from when given.
    let recorded = read_note(&a.paths[0])?;
    let src = mapping_for(
        a.from.as_deref(),
        a.from_preset.as_deref(),
        recorded.as_ref(),
        None,
    )
    .context("--from/--from-preset")?;
    let Some(src) = src else {
        bail!(
            "--from: {} records no mapping (spheremap records one in the EXR, PNG, JPEG and HDR \
             maps it writes); name it with --from",
            a.paths[0]
        )
    };
    if let (Some(t), false) = (&recorded, a.job.quiet) {
        if (t.mapping.name(), t.mapping.preset_name()) != (src.name(), src.preset_name()) {
            eprintln!(
                "note: {} records mapping {} (preset {}); converting it as {} (preset {})",
                a.paths[0],
                t.mapping.name(),
                t.mapping.preset_name(),
                src.name(),
                src.preset_name()
            );
        }
    }
    // No --to: the same mapping (its preset unless --preset), layout and view as the input.
    let same = a.to.is_none();
    let dst = match &a.to {
        Some(to) => Mapping::parse(to, a.preset.as_deref()).context("--to/--preset")?,
        None => match a.preset.as_deref() {
            Some(p) => Mapping::parse(src.name(), Some(p)).context("--preset")?,
            None => src,
        },
    };
    let layout = a.layout.as_deref().map(Layout::parse).transpose()?;
    let from_layout = layout_for(a.from_layout.as_deref(), recorded.as_ref(), src)?;
    let precision = Precision::parse(&a.precision)?;
    let ypr = (a.yaw.is_some() || a.pitch.is_some() || a.roll.is_some()).then(|| {
        [
            a.yaw.unwrap_or(0.0),
            a.pitch.unwrap_or(0.0),
            a.roll.unwrap_or(0.0),
        ]
    });
    // The input's view: --from-look/--from-up, else the one IN records (when the note is what
    // IN is read as).
    let note_applies = recorded.is_some_and(|t| {
        (t.mapping.name(), t.mapping.preset_name()) == (src.name(), src.preset_name())
    });
    let (from_look, from_up) = match (vec3(&a.from_look), recorded.and_then(|t| t.view)) {
        (None, Some((l, u))) if note_applies && a.from_up.is_none() => (Some(l), Some(u)),
        _ => (vec3(&a.from_look), vec3(&a.from_up)),
    };
    // Without --to and any output view, the output keeps the input's view.
    let (look, up) = match (same && a.look.is_none() && ypr.is_none(), from_look) {
        (true, Some(l)) => (Some(l), from_up),
        _ => (vec3(&a.look), vec3(&a.up)),
    };
    let rotation = view::conversion_rotation(look, up, ypr, from_look, from_up)?;
    let out_view = view::output_view(look, up, ypr)?;
    let (input, output) = split_paths(
        &a.paths,
        matches!(src, Mapping::Cube(_)),
        matches!(dst, Mapping::Cube(_)),
    )?;
    if let (Some(f), EnvFiles::One(p)) = (recorded.and_then(|t| t.face), &input) {
        if matches!(src, Mapping::Cube(_)) {
            bail!(
                "{p}: one face ({}) of a cube map of six files; give all six, or a pattern such \
                 as 'sky_{{face}}.exr'",
                spheremap::mappings::cube::FACE_NAMES[f]
            );
        }
    }
    a.job.refuse_overwrite(&input.paths(), &output.paths())?;
    output.check_output(dst)?;
    let ropts = ReadOptions {
        linear: a.linear,
        ..Default::default()
    };
    let nonfinite = a.job.nonfinite()?;
    let max_memory = a.job.max_memory()?;
    let (mut img, in_layout) = read_env_layout(&input, src, from_layout, &ropts)?;
    let layout = layout.or(if same { in_layout } else { None });
    let label = input.label();
    check_nonfinite_env(&mut img, &input, nonfinite)?;
    let env = EnvMap::new(src, &img, input.first())?;
    let n = match a.size {
        Some(n) => n,
        None => default_size(src, src.size_of(img.width, img.height, input.first())?, dst),
    };
    spheremap::base::error::check_map_size("size", n)?;
    let (w, h) = dst.canvas(n);
    let opts = ResampleOptions {
        samples: a.sampling.samples,
        max_samples: a.sampling.max_samples,
        filter: a.sampling.filter()?,
        taps: Taps::parse(&a.taps)?,
        outside: a.sampling.outside()?,
        rotation,
        seed: a.sampling.seed,
        precision,
        max_memory,
    };
    let t0 = Instant::now();
    let progress = Progress::default();
    let (out, report) = std::thread::scope(|s| {
        let work = s.spawn(|| resample(&env, dst, w, h, &opts, Some(&progress)));
        crate::progress::watch(&progress, &work, a.job.show_progress(), "converting");
        work.join().expect("the conversion thread panicked")
    })?;
    let seconds = t0.elapsed().as_secs_f64();
    let wopts = a.job.write_options(a.linear);
    let written = write_env_files(&output, dst, &out, layout, &out_view, &wopts)?;
    if a.job.json {
        let mut v = serde_json::json!({
            "input": label, "inputs": input.paths(), "output": written,
            "from": src.name(), "from_preset": src.preset_name(),
            "from_look": from_look, "from_up": from_up,
            "to": dst.name(), "preset": dst.preset_name(),
            "size": n, "width": w, "height": h, "channels": out.channels,
            "samples": a.sampling.samples, "filter": opts.filter.name(), "taps": opts.taps.name(), "outside": opts.outside.name(),
            "lookups": report.lookups, "max_texel_samples": report.max_texel_samples,
            "copied": report.copied,
            "seconds": seconds,
        });
        a.job.add_losses(&mut v, &out, &written[0], a.linear);
        crate::out(&format!("{v}\n"));
    } else if !a.job.quiet && report.copied {
        eprintln!(
            "{} ({} {}) -> {} ({w}x{h}): the same mapping, size and view: texels copied, {:.3} s",
            label,
            src.name(),
            src.preset_name(),
            written.join(", "),
            seconds
        );
    } else if !a.job.quiet {
        eprintln!(
            "{} ({} {}) -> {} ({} {}, {w}x{h}): {:.1} lookups/texel, {:.3} s",
            label,
            src.name(),
            src.preset_name(),
            written.join(", "),
            dst.name(),
            dst.preset_name(),
            report.lookups as f64 / (w * h) as f64,
            seconds
        );
    }
    Ok(())
}
