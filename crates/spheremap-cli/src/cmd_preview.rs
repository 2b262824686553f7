//! `spheremap preview`: a photo of a scene (or an environment map) through a perspective or
//! fisheye camera, ray traced — to look at a scene before making maps from it, or to make
//! test photos of a mirror ball (its flags as `spheremap::trace::camera::PreviewRequest` and
//! `jobs::scene::SceneRequest`, run by `SceneRequest::preview_files`).

use crate::job::vec3;
use spheremap::mappings::fisheye::LensName;
use spheremap::trace::camera::PreviewRequest;

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
    request.camera().map_err(crate::flag_error)?;
    a.world
        .refuse_overwrite(&a.job, std::slice::from_ref(&a.output))?;
    let scene = a.world.request(a.job.nonfinite()?, a.seed);
    let wopts = a.job.write_options(false);
    let report = crate::progress::run(a.job.show_progress(), "rendering", |p| {
        scene.preview_files(&request, a.world.env.as_deref(), &a.output, &wopts, Some(p))
    })
    .map_err(crate::scene_args::flag_error)?;
    let words = crate::Words::Stderr { quiet: a.job.quiet };
    crate::print_report(&report, a.job.json, words);
    Ok(())
}
