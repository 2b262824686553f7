//! `spheremap render`: its flags as the core's `jobs::render::RenderRequest` and `RenderFiles`,
//! run and reported.

use crate::camera_args::CameraArgs;
use crate::job::JobFlags;
use spheremap::jobs::render::{RenderFiles, RenderRequest};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The mesh: OBJ or glTF/GLB (its vertex normals when present, else angle-weighted ones).
    mesh: String,
    /// The environment: a sphere map (per-vertex, per-pixel), a MatCap image (matcap), or any
    /// mapping with --from (per-pixel). Not needed for normals and error.
    #[arg(long)]
    env: Option<String>,
    #[command(flatten)]
    source: crate::source_args::SourceArgs,
    /// per-vertex (GL_SPHERE_MAP texgen, as OpenGL), per-pixel, matcap, normals, error.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::jobs::render::ModeName>())]
    mode: spheremap::jobs::render::ModeName,
    /// MatCap variant for --mode matcap: classic, threejs, perspective.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::mappings::matcap::MatcapVariant>())]
    matcap_variant: spheremap::mappings::matcap::MatcapVariant,
    #[command(flatten)]
    camera: CameraArgs,
    /// Image size in pixels.
    #[arg(long, num_args = 2, value_names = ["W", "H"], default_values_t = [RenderRequest::default().view.width, RenderRequest::default().view.height])]
    size: Vec<usize>,
    /// Colour where no triangle is (linear RGB).
    #[arg(long, num_args = 3, value_names = ["R", "G", "B"], default_values_t = [0.0, 0.0, 0.0])]
    background: Vec<f32>,
    /// Anti-aliasing: K × K samples per pixel (1 = the pixel centre, as GL without MSAA).
    #[arg(long, default_value_t = RenderRequest::default().aa)]
    aa: u32,
    /// Sub-pixel precision of the vertex snapping, in bits (1-8): 8 as Mesa's llvmpipe and
    /// D3D11-class GPUs; 4 as SwiftShader (Chromium without a GPU), the least GL allows. A GPU
    /// reports its own as GL_SUBPIXEL_BITS.
    #[arg(long, default_value_t = RenderRequest::default().subpixel_bits)]
    subpixel_bits: u32,
    /// Texture wrap of a sphere map or MatCap: clamp-to-edge (default) or repeat.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::jobs::render::Wrap>())]
    wrap: spheremap::jobs::render::Wrap,
    /// Exposure in stops for PNG/JPEG outputs (EXR/HDR/PFM stay linear and untouched).
    #[arg(long, default_value_t = RenderFiles::default().exposure, allow_negative_numbers = true)]
    exposure: f32,
    /// Tone-mapping operator for PNG/JPEG outputs: clamp (default), reinhard, aces.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::images::tonemap::ToneMap>())]
    tonemap: spheremap::images::tonemap::ToneMap,
    /// Error mode: the angle (degrees) shown as the hottest colour in PNG/JPEG outputs
    /// (EXR holds the degrees themselves).
    #[arg(long, default_value_t = RenderFiles::default().error_max)]
    error_max: f32,
    /// A turntable: N frames with the eye orbiting the target about --up (a full turn); -o is
    /// an animated GIF (.gif) or a pattern with {frame} for numbered images.
    #[arg(long)]
    turntable: Option<u32>,
    /// Milliseconds per frame of the animated GIF.
    #[arg(long, default_value_t = RenderFiles::default().frame_ms)]
    frame_ms: u32,
    /// Read LDR textures as linear values (no sRGB decoding).
    #[arg(long)]
    linear: bool,
    /// Output image (.exr .hdr .pfm: linear values; .png .jpg: tone-mapped, sRGB).
    #[arg(short = 'o', long)]
    output: String,
    #[command(flatten)]
    job: JobFlags,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let request = RenderRequest {
        mode: a.mode,
        matcap_variant: a.matcap_variant,
        background: [a.background[0], a.background[1], a.background[2]],
        aa: a.aa,
        subpixel_bits: a.subpixel_bits,
        wrap: a.wrap,
        view: a.camera.request((a.size[0], a.size[1])),
    };
    let files = RenderFiles {
        source: a.source.source(),
        nonfinite: a.job.nonfinite,
        linear: a.linear,
        exposure: a.exposure,
        tonemap: a.tonemap,
        error_max: a.error_max,
        turntable: a.turntable,
        frame_ms: a.frame_ms,
    };
    let inputs: Vec<&String> = std::iter::once(&a.mesh).chain(&a.env).collect();
    a.job.refuse_overwrite(&inputs, &[&a.output])?;
    let report = request
        .run_files(
            &a.mesh,
            a.env.as_deref(),
            &files,
            &a.output,
            &a.job.write_options(false),
        )
        .map_err(|e| crate::flag_error(e.renamed("output", "-o")))?;
    let words = crate::Words::Stderr { quiet: a.job.quiet };
    crate::print_report(&report, a.job.json, words);
    Ok(())
}
