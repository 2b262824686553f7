//! `spheremap render`: a thin layer over `spheremap::jobs::render`.

use crate::camera_args::CameraArgs;
use crate::job::JobFlags;
use anyhow::{bail, Context};
use spheremap::images::codec::{check_nonfinite, write_image, ReadOptions};
use spheremap::images::envmap::read_env;
use spheremap::images::format::Format;
use spheremap::images::tonemap::{tone_map, ToneMap};
use spheremap::images::Image;
use spheremap::jobs::render::{
    self, heat_colour, Env, EnvInput, GlCamera, Mode, PixelError, RenderOptions, RenderRequest,
    RenderSummary,
};
use spheremap::mesh::load_mesh;
use std::path::Path;
use std::time::Instant;

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
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Tone-mapping operator for PNG/JPEG outputs: clamp (default), reinhard, aces.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::images::tonemap::ToneMap>())]
    tonemap: spheremap::images::tonemap::ToneMap,
    /// Error mode: the angle (degrees) shown as the hottest colour in PNG/JPEG outputs
    /// (EXR holds the degrees themselves).
    #[arg(long, default_value_t = 5.0)]
    error_max: f32,
    /// A turntable: N frames with the eye orbiting the target about --up (a full turn); -o is
    /// an animated GIF (.gif) or a pattern with {frame} for numbered images.
    #[arg(long)]
    turntable: Option<u32>,
    /// Milliseconds per frame of the animated GIF.
    #[arg(long, default_value_t = 80)]
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
    let mode = request.mode();
    let wrap = request.wrap;
    let op = a.tonemap;
    if !(a.error_max > 0.0 && a.error_max.is_finite()) {
        bail!("error-max: must be a positive number of degrees");
    }
    let inputs: Vec<&String> = std::iter::once(&a.mesh).chain(&a.env).collect();
    a.job.refuse_overwrite(&inputs, &[&a.output])?;
    let mesh = load_mesh(Path::new(&a.mesh))?;
    let cam = request
        .camera(&mesh.positions)
        .with_context(|| a.mesh.clone())?;
    let (mapping, layout) = a
        .source
        .mapping(a.env.as_deref().unwrap_or(""), "sphere", "render")?;
    let env_img: Option<Image> = match (&a.env, mode) {
        (None, Mode::Normals | Mode::Error) => None,
        (None, _) => bail!("--env: mode {} needs an environment map", a.mode),
        (Some(e), _) => {
            let ropts = ReadOptions {
                linear: a.linear,
                ..Default::default()
            };
            let mut img = read_env(e, mapping, layout, &ropts)?;
            check_nonfinite(&mut img, a.job.nonfinite()?, e)?;
            Some(img)
        }
    };
    let what = a.env.as_deref().unwrap_or("env");
    let (mapping, env_img) = request.environment(mapping, env_img, what)?;
    let input = EnvInput::new(mapping, env_img.as_ref(), wrap, what)?;
    input.check(mode).map_err(crate::flag_error)?;
    let env = input.env();
    let opts = request.options()?;
    if let Some(n) = a.turntable {
        return turntable(&a, n, &mesh, &cam, env, &opts, op);
    }
    let t0 = Instant::now();
    let (img, stats) = render::render(&mesh, &cam, env, &opts)?;
    let seconds = t0.elapsed().as_secs_f64();
    let error_stats = (mode == Mode::Error).then(|| PixelError::of(&img));
    let linear_out = Format::from_extension(Path::new(&a.output)).is_some_and(|f| !f.is_ldr());
    let out = finish(img, &a, &opts, op, linear_out);
    write_image(Path::new(&a.output), &out, &a.job.write_options(false))?;
    let losses = a.job.losses(&out, &a.output, false);
    let report = RenderSummary {
        output: a.output.clone(),
        mode: a.mode.to_string(),
        width: cam.width,
        height: cam.height,
        triangles_drawn: stats.triangles,
        covered_pixels: stats.covered_pixels,
        modelview: cam.modelview,
        projection: cam.projection,
        seconds,
        clipped: losses.clipped,
        clamped_half: losses.beyond_half,
        error_deg: error_stats,
        error_scale_deg: error_stats.map(|_| a.error_max as f64),
    };
    let words = crate::Words::Stderr { quiet: a.job.quiet };
    crate::print_report(&report, a.job.json, words);
    Ok(())
}

/// Display-ready: the error heat map or the tone-mapped colours, unless the output is linear.
fn finish(img: Image, a: &Args, opts: &RenderOptions, op: ToneMap, linear_out: bool) -> Image {
    if linear_out {
        img
    } else if opts.mode == Mode::Error {
        heat_image(&img, a.error_max, opts.background)
    } else {
        let mut i = img;
        tone_map(&mut i, a.exposure, op);
        i
    }
}

fn turntable(
    a: &Args,
    n: u32,
    mesh: &spheremap::mesh::Mesh,
    cam: &GlCamera,
    env: Env,
    opts: &RenderOptions,
    op: ToneMap,
) -> anyhow::Result<()> {
    spheremap::base::limits::check_range(
        "turntable",
        n,
        1,
        spheremap::base::limits::TURNTABLE_FRAMES,
    )?;
    let gif = a.output.to_ascii_lowercase().ends_with(".gif");
    if !gif && !a.output.contains("{frame}") {
        bail!(
            "{}: with --turntable, -o is a .gif or a pattern with {{frame}}",
            a.output
        );
    }
    let linear_out =
        !gif && Format::from_extension(Path::new(&a.output)).is_some_and(|f| !f.is_ldr());
    let t0 = Instant::now();
    let mut frames = Vec::with_capacity(n as usize);
    for k in 0..n {
        let c = cam.orbited(360.0 * k as f64 / n as f64)?;
        let (img, _) = render::render(mesh, &c, env, opts)?;
        frames.push(finish(img, a, opts, op, linear_out));
    }
    let written = if gif {
        spheremap::images::codec::write_gif(Path::new(&a.output), &frames, a.frame_ms)?;
        vec![a.output.clone()]
    } else {
        let digits = (n - 1).to_string().len().max(3);
        let mut w = vec![];
        for (k, f) in frames.iter().enumerate() {
            let p = a.output.replace("{frame}", &format!("{k:0digits$}"));
            write_image(Path::new(&p), f, &a.job.write_options(false))?;
            w.push(p);
        }
        w
    };
    let seconds = t0.elapsed().as_secs_f64();
    let report = render::TurntableReport {
        output: written,
        frames: n,
        mode: a.mode,
        width: cam.width,
        height: cam.height,
        seconds,
    };
    let words = crate::Words::Stderr { quiet: a.job.quiet };
    crate::print_report(&report, a.job.json, words);
    Ok(())
}

/// Mean, 95th percentile and maximum of the angle over the covered pixels.
/// (degrees, coverage) → heat colours (0 → dark, `max` and above → pale yellow) over the
/// background by coverage.
fn heat_image(img: &Image, max: f32, bg: [f32; 3]) -> Image {
    let mut out = Image::new(img.width, img.height, 3);
    for (o, p) in out.data.chunks_exact_mut(3).zip(img.data.chunks_exact(2)) {
        let h = heat_colour(p[0] / max);
        for k in 0..3 {
            o[k] = p[1] * h[k] + (1.0 - p[1]) * bg[k];
        }
    }
    out
}
