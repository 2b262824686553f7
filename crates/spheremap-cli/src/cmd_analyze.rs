//! `spheremap analyze`: its flags as the core's `jobs::analyze::AnalyzeRequest`, run and reported.

use crate::camera_args::CameraArgs;
use crate::job::JobFlags;
use spheremap::jobs::analyze::AnalyzeRequest;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// An environment map whose mapping (--mapping) and size are analysed.
    map: Option<String>,
    /// The mapping: sphere (default), latlong, cube, angular, paraboloid, octahedral.
    #[arg(long, default_value_t = AnalyzeRequest::default().mapping, value_parser = crate::names::core("mapping"))]
    mapping: String,
    /// Its preset.
    #[arg(long)]
    preset: Option<String>,
    /// Canvas size N without MAP (sphere N×N, latlong 2N×N, cube faces N×N...).
    #[arg(long, default_value_t = AnalyzeRequest::default().size)]
    size: usize,
    /// A mesh: per-vertex interpolation error, triangles over --threshold, tessellation advice.
    #[arg(long)]
    mesh: Option<String>,
    #[command(flatten)]
    camera: CameraArgs,
    /// Size of the mesh's error heat map.
    #[arg(long, num_args = 2, value_names = ["W", "H"], default_values_t = [AnalyzeRequest::default().view.width, AnalyzeRequest::default().view.height])]
    view_size: Vec<usize>,
    /// Error threshold in degrees for the triangle list and the tessellation advice.
    #[arg(long, default_value_t = AnalyzeRequest::default().threshold)]
    threshold: f64,
    /// The figure (PNG/JPEG; panels with colour bars and legends).
    #[arg(short = 'o', long)]
    output: String,
    #[command(flatten)]
    job: JobFlags,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let request = AnalyzeRequest {
        mapping: a.mapping.clone(),
        preset: a.preset.clone(),
        size: a.size,
        view: a.camera.request((a.view_size[0], a.view_size[1])),
        threshold: a.threshold,
    };
    let inputs: Vec<&String> = a.map.iter().chain(&a.mesh).collect();
    a.job.refuse_overwrite(&inputs, &[&a.output])?;
    let summary = request
        .run_files(
            a.map.as_deref(),
            a.mesh.as_deref(),
            &a.output,
            &a.job.write_options(false),
        )
        .map_err(|e| {
            let e = e
                .renamed("width", "view_size")
                .renamed("height", "view_size");
            crate::flag_error(e)
        })?;
    let words = crate::Words::Stderr { quiet: a.job.quiet };
    crate::print_report(&summary, a.job.json, words);
    Ok(())
}
