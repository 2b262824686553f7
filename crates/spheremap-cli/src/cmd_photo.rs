//! `spheremap from-photo` (mirror-ball photos) and `spheremap from-fisheye`: their flags, as
//! the core's `jobs::photo::BallRequest` and `FisheyeRequest`, run on files.

use crate::job::JobFlags;
use spheremap::images::codec::WriteOptions;
use spheremap::jobs::photo::{BallRequest, FisheyeRequest, PhotoRunReport, Reflectance};
use spheremap::mappings::fisheye::LensName;
use spheremap::resample::Progress;
use spheremap::trace::generate::MapRequest;

/// The output side, shared by both commands.
#[derive(clap::Args, Debug)]
pub struct MapOut {
    /// Output mapping (default sphere: the GL sphere map of the camera's view).
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
    #[command(flatten)]
    view: crate::view_args::ViewArgs,
    /// What to put where no photo sees: none (0, default), smooth (pull-push interpolation
    /// from the seen texels), mean (their mean colour).
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::jobs::photo::Fill>())]
    fill: spheremap::jobs::photo::Fill,
    /// Write the confidence mask here (one channel, 0 = unseen, 1 = best sampled).
    #[arg(long)]
    mask: Option<String>,
    /// Read/write LDR files as linear values (no sRGB transfer).
    #[arg(long)]
    linear: bool,
    /// Output file (.exr .hdr .pfm .png .jpg), or a {face} pattern with --to cube.
    #[arg(short = 'o', long)]
    output: String,
    #[command(flatten)]
    job: JobFlags,
}

impl MapOut {
    /// The output map as the core's request.
    fn request(&self) -> anyhow::Result<MapRequest> {
        Ok(MapRequest {
            to: self.to.clone(),
            preset: self.preset.clone(),
            layout: self.layout.clone(),
            size: self.size,
            look: self.view.get().0,
            up: self.view.get().1,
            samples: self.sampling.samples,
            max_samples: self.sampling.max_samples,
            filter: self.sampling.filter,
            outside: self.sampling.outside,
            seed: self.sampling.seed,
            max_memory: Some(self.job.max_memory()?),
            ..Default::default()
        })
    }

    /// Runs a route on files with the job's flags, and prints its report.
    fn run(
        &self,
        go: impl FnOnce(&WriteOptions, bool, Option<&Progress>) -> spheremap::Result<PhotoRunReport>
            + Send,
    ) -> anyhow::Result<()> {
        let wopts = self.job.write_options(self.linear);
        let report = crate::progress::run(self.job.show_progress(), "unwarping", |p| {
            go(&wopts, self.job.force, Some(p))
        })
        .map_err(crate::flag_error)?;
        let words = crate::Words::Stderr {
            quiet: self.job.quiet,
        };
        crate::print_report(&report, self.job.json, words);
        Ok(())
    }
}

#[derive(clap::Args, Debug)]
pub struct PhotoArgs {
    /// The photo of the mirror ball.
    ball: String,
    /// A second photo of the ball, taken from about --angle degrees around it: the camera
    /// and the grazing rim of each photo are replaced by the other.
    #[arg(long)]
    second: Option<String>,
    /// Where the second camera stood, in degrees around the ball from the first (positive:
    /// to the first camera's right); refined by aligning the photos.
    #[arg(long, default_value_t = BallRequest::default().angle, allow_negative_numbers = true)]
    angle: f64,
    /// Use --angle as is (no alignment).
    #[arg(long)]
    no_align: bool,
    /// Horizontal field of view of the photo(s) in degrees (default: from EXIF).
    #[arg(long)]
    fov: Option<f64>,
    /// Focal length in mm (with --sensor).
    #[arg(long)]
    focal: Option<f64>,
    /// Sensor width in mm (with --focal, or with the EXIF focal length).
    #[arg(long)]
    sensor: Option<f64>,
    /// Assume an orthographic camera (the classic assumption; no field of view needed).
    #[arg(long)]
    orthographic: bool,
    /// The ball's outline in the first photo: centre and radius in continuous pixel
    /// coordinates ((0,0) the top-left corner, pixel centres at i + 0.5); default: found.
    #[arg(long, num_args = 3, value_names = ["CX", "CY", "R"], allow_negative_numbers = true)]
    circle: Option<Vec<f64>>,
    /// The ball's outline in the second photo (default: found).
    #[arg(long, num_args = 3, value_names = ["CX", "CY", "R"], allow_negative_numbers = true)]
    circle2: Option<Vec<f64>>,
    /// The ball's reflectance (one value, or R G B): the photo is divided by it (a chrome
    /// ball reflects about 0.6 to 0.8).
    #[arg(long, num_args = 1..=3, value_names = ["R"])]
    reflectance: Option<Vec<f32>>,
    /// Radius in degrees around the direction back to the camera whose confidence is 0 (the
    /// camera and the photographer).
    #[arg(long, default_value_t = BallRequest::default().camera_radius)]
    camera_radius: f64,
    #[command(flatten)]
    out: MapOut,
}

pub fn run_photo(a: PhotoArgs) -> anyhow::Result<()> {
    let request = BallRequest {
        angle: a.angle,
        align: !a.no_align,
        fov: a.fov,
        focal: a.focal,
        sensor: a.sensor,
        orthographic: a.orthographic,
        circle: crate::job::vec3(&a.circle),
        circle2: crate::job::vec3(&a.circle2),
        reflectance: a.reflectance.map(Reflectance::Rgb),
        camera_radius: a.camera_radius,
        fill: a.out.fill,
        linear: a.out.linear,
        nonfinite: a.out.job.nonfinite()?,
        map: a.out.request()?,
    };
    a.out.run(|w, force, p| {
        let mask = a.out.mask.as_deref();
        request.run_files(
            &a.ball,
            a.second.as_deref(),
            &a.out.output,
            mask,
            w,
            force,
            p,
        )
    })
}

#[derive(clap::Args, Debug)]
pub struct FisheyeArgs {
    /// The fisheye photo.
    image: String,
    /// Lens model: equidistant, equisolid, stereographic, orthographic, polynomial.
    #[arg(long, value_parser = crate::names::core("lens"))]
    model: String,
    /// Field of view across the image circle, degrees.
    #[arg(long)]
    fov: f64,
    /// Optical centre in continuous pixel coordinates (default: the image centre).
    #[arg(long, num_args = 2, value_names = ["CX", "CY"], allow_negative_numbers = true)]
    centre: Option<Vec<f64>>,
    /// Radius of the image circle in pixels (where the angle is fov/2; default: half the
    /// shorter side).
    #[arg(long)]
    radius: Option<f64>,
    /// Polynomial model: r/f = θ(1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸) (OpenCV's fisheye).
    #[arg(long, num_args = 4, value_names = ["K1", "K2", "K3", "K4"], allow_negative_numbers = true)]
    k: Option<Vec<f64>>,
    #[command(flatten)]
    out: MapOut,
}

pub fn run_fisheye(a: FisheyeArgs) -> anyhow::Result<()> {
    let request = FisheyeRequest {
        model: Some(LensName::parse_as(&a.model, "model")?),
        fov: Some(a.fov),
        centre: a.centre.as_deref().map(|c| [c[0], c[1]]),
        radius: a.radius,
        k: a.k.as_deref().map(|k| [k[0], k[1], k[2], k[3]]),
        fill: a.out.fill,
        linear: a.out.linear,
        nonfinite: a.out.job.nonfinite()?,
        map: a.out.request()?,
    };
    a.out.run(|w, force, p| {
        let mask = a.out.mask.as_deref();
        request.run_files(&a.image, &a.out.output, mask, w, force, p)
    })
}
