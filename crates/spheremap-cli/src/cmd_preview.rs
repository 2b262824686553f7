//! `spheremap preview`: a photo of a scene (or an environment map) through a perspective or
//! fisheye camera, ray traced — to look at a scene before making maps from it, or to make
//! test photos of a mirror ball (its flags as `spheremap::trace::camera::PreviewRequest`).

use crate::job::vec3;
use spheremap::images::codec::write_image;
use spheremap::mappings::fisheye::LensName;
use spheremap::trace::camera::{self, PreviewRequest};
use std::path::Path;
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    world: crate::scene_args::SceneArgs,
    /// Where the camera stands.
    #[arg(long, required = true, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    eye: Vec<f64>,
    /// The point it looks at.
    #[arg(long, required = true, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    target: Vec<f64>,
    /// Its up direction (default 0 1 0), as gluLookAt.
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    up: Option<Vec<f64>>,
    /// Horizontal field of view in degrees (perspective camera).
    #[arg(long, default_value_t = PreviewRequest::default().fov)]
    fov: f64,
    /// A fisheye lens instead: equidistant, equisolid, stereographic, orthographic (its image
    /// circle fills the shorter side; --fov is then the field across the circle).
    #[arg(long, value_parser = crate::names::typed::<LensName>())]
    lens: Option<LensName>,
    /// Image size in pixels.
    #[arg(long, num_args = 2, value_names = ["W", "H"], default_values_t = [PreviewRequest::default().width, PreviewRequest::default().height])]
    size: Vec<usize>,
    /// Rays per pixel (jittered grid; 1 = through the pixel centre).
    #[arg(long, default_value_t = PreviewRequest::default().samples)]
    samples: u32,
    /// Seed of the jitter and the scene's random rays.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output image (.exr .hdr .pfm .png .jpg; PNG/JPEG are sRGB-encoded, clipped).
    #[arg(short = 'o', long)]
    output: String,
    #[command(flatten)]
    job: crate::job::JobFlags,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let (w, h) = (a.size[0], a.size[1]);
    let request = PreviewRequest {
        eye: vec3(&Some(a.eye.clone())),
        target: vec3(&Some(a.target.clone())),
        up: vec3(&a.up).unwrap_or(PreviewRequest::default().up),
        fov: a.fov,
        lens: a.lens,
        width: w,
        height: h,
        samples: a.samples,
        seed: a.seed,
        max_memory: Some(a.job.max_memory()?),
    };
    let cam = request.camera().map_err(crate::flag_error)?;
    let world = a
        .world
        .load(&a.job, a.seed, std::slice::from_ref(&a.output))?;
    let source = world.source();
    let t0 = Instant::now();
    let img = crate::progress::run(a.job.show_progress(), "rendering", |p| {
        camera::render(&cam, source.as_ref(), a.samples, a.seed, false, Some(p))
    })?;
    let seconds = t0.elapsed().as_secs_f64();
    write_image(Path::new(&a.output), &img, &a.job.write_options(false))?;
    let losses = a.job.losses(&img, &a.output, false).into();
    let report = cam.report(&a.output, a.samples, seconds, losses);
    let words = crate::Words::Stderr { quiet: a.job.quiet };
    crate::print_report(&report, a.job.json, words);
    Ok(())
}
