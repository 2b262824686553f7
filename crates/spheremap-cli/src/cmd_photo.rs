//! `spheremap from-photo` (mirror-ball photos) and `spheremap from-fisheye`: thin layers over
//! `spheremap::jobs::photo`.

use crate::job::JobFlags;
use anyhow::{bail, Context};
use spheremap::images::codec::{check_nonfinite, read_image, ReadOptions};
use spheremap::images::envmap::{write_env, EnvFiles};
use spheremap::images::Image;
use spheremap::jobs::photo::{self, BallModel, BallPhoto, Circle, Fill, PhotoOptions, PhotoReport};
use spheremap::mappings::fisheye::{Lens, LensModel};
use spheremap::mappings::mapping::Mapping;
use spheremap::trace::generate::{MapRequest, ResolvedMap};
use std::path::Path;
use std::time::Instant;

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
    /// The output map as the core's request, checked.
    fn map(&self) -> anyhow::Result<ResolvedMap> {
        let request = MapRequest {
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
        };
        request.resolve().map_err(crate::flag_error)
    }

    fn options(&self) -> anyhow::Result<(PhotoOptions, Mapping)> {
        let map = self.map()?;
        Ok((
            PhotoOptions {
                mapping: map.mapping,
                width: map.width,
                height: map.height,
                generate: map.options,
                fill: self.fill,
                ..Default::default()
            },
            map.mapping,
        ))
    }

    /// Refuses outputs that would overwrite an input, or that cannot be written as `dst`
    /// (checked before any work).
    fn check_outputs(&self, inputs: &[&str], dst: Mapping) -> anyhow::Result<()> {
        let mut outs = vec![self.output.as_str()];
        outs.extend(self.mask.as_deref());
        self.job.refuse_overwrite(inputs, &outs)?;
        for o in outs {
            EnvFiles::parse(o).check_output(dst)?;
        }
        Ok(())
    }

    fn read(&self, path: &str) -> anyhow::Result<Image> {
        let ropts = ReadOptions {
            linear: self.linear,
            ..Default::default()
        };
        let mut img = read_image(Path::new(path), &ropts)?;
        check_nonfinite(&mut img, self.job.nonfinite()?, path)?;
        Ok(img)
    }

    fn write(&self, dst: Mapping, map: &Image, mask: &Image) -> anyhow::Result<Vec<String>> {
        // The map's layout and its view, in the camera's frame.
        let ResolvedMap { layout, view, .. } = self.map()?;
        let wopts = self.job.write_options(self.linear);
        let mut written = write_env(&self.output, dst, map, layout, &view, &wopts)?;
        if let Some(m) = &self.mask {
            // The mask is data: written linear whatever the format.
            let mopts = self.job.write_options(true);
            written.extend(write_env(m, dst, mask, layout, &view, &mopts)?);
        }
        Ok(written)
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
    #[arg(long, default_value_t = 90.0, allow_negative_numbers = true)]
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
    #[arg(long, default_value_t = 20.0)]
    camera_radius: f64,
    #[command(flatten)]
    out: MapOut,
}

fn circle_of(v: &Option<Vec<f64>>) -> Option<Circle> {
    v.as_ref().map(|v| Circle {
        cx: v[0],
        cy: v[1],
        r: v[2],
    })
}

/// The camera model of one photo (its own EXIF when no flag says).
fn model_of(a: &PhotoArgs, path: &str, img: &Image) -> anyhow::Result<(BallModel, String)> {
    if a.orthographic {
        return Ok((BallModel::Orthographic, "orthographic".into()));
    }
    let bytes = if a.fov.is_none() && a.focal.is_none() {
        Some(spheremap::base::files::read_file(Path::new(path))?)
    } else {
        None
    };
    let (hfov, from) = photo::exif_hfov(
        a.fov,
        a.focal,
        a.sensor,
        bytes.as_deref(),
        img.width,
        img.height,
    )
    .with_context(|| path.to_string())?;
    Ok((
        BallModel::Perspective { hfov_deg: hfov },
        format!(
            "perspective, horizontal field of view {hfov:.3}° ({})",
            from.describe()
        ),
    ))
}

pub fn run_photo(a: PhotoArgs) -> anyhow::Result<()> {
    let (mut opts, dst) = a.out.options()?;
    let mut inputs = vec![a.ball.as_str()];
    inputs.extend(a.second.as_deref());
    a.out.check_outputs(&inputs, dst)?;
    opts.reflectance = match a.reflectance.as_deref() {
        None => [1.0; 3],
        Some([r]) => [*r; 3],
        Some([r, g, b]) => [*r, *g, *b],
        Some(_) => bail!("reflectance: give one value or three (R G B)"),
    };
    opts.camera_radius_deg = a.camera_radius;
    opts.angle_deg = a.angle;
    opts.align = !a.no_align;
    let img1 = a.out.read(&a.ball)?;
    let (m1, d1) = model_of(&a, &a.ball, &img1)?;
    let img2 = a.second.as_deref().map(|p| a.out.read(p)).transpose()?;
    let m2 = match (&a.second, &img2) {
        (Some(p), Some(i)) => Some(model_of(&a, p, i)?),
        _ => None,
    };
    let p1 = BallPhoto {
        image: &img1,
        model: m1,
        circle: circle_of(&a.circle),
    };
    let p2 = img2.as_ref().zip(m2.as_ref()).map(|(i, (m, _))| BallPhoto {
        image: i,
        model: *m,
        circle: circle_of(&a.circle2),
    });
    let t0 = Instant::now();
    let result = crate::progress::run(a.out.job.show_progress(), "unwarping", |p| {
        photo::from_mirror_ball(&p1, p2.as_ref(), &opts, Some(p))
    });
    // Name the photo in errors about it.
    let (map, mask, report) = result.map_err(|e| anyhow::anyhow!(name_photo(&e, &a)))?;
    let seconds = t0.elapsed().as_secs_f64();
    let written = a.out.write(dst, &map, &mask)?;
    let models: Vec<String> = std::iter::once(d1).chain(m2.map(|m| m.1)).collect();
    summary(
        &a.out, dst, &map, &report, &models, seconds, &written, &inputs,
    );
    Ok(())
}

/// The core says "photo"/"second" for its arguments; the CLI names the files.
fn name_photo(e: &spheremap::Error, a: &PhotoArgs) -> String {
    let msg = e.to_string();
    if let Some(rest) = msg.strip_prefix("photo: ") {
        format!("{}: {rest}", a.ball)
    } else if let (Some(rest), Some(p)) = (msg.strip_prefix("second: "), &a.second) {
        format!("{p}: {rest}")
    } else {
        msg
    }
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
    let (opts, dst) = a.out.options()?;
    a.out.check_outputs(&[a.image.as_str()], dst)?;
    let k =
        a.k.as_deref()
            .map_or([0.0; 4], |k| [k[0], k[1], k[2], k[3]]);
    if a.k.is_some() && a.model != "polynomial" {
        bail!("k: only the polynomial model takes coefficients");
    }
    let model = LensModel::parse(&a.model, k)?;
    let img = a.out.read(&a.image)?;
    let centre = a
        .centre
        .as_deref()
        .map_or([0.5 * img.width as f64, 0.5 * img.height as f64], |c| {
            [c[0], c[1]]
        });
    let radius = a.radius.unwrap_or(0.5 * img.width.min(img.height) as f64);
    let lens = Lens::new(model, a.fov, centre, radius)?;
    let t0 = Instant::now();
    let (map, mask, report) = crate::progress::run(a.out.job.show_progress(), "unwarping", |p| {
        photo::from_fisheye(&img, lens, &opts, Some(p))
    })
    .map_err(|e| anyhow::anyhow!("{}: {e}", a.image))?;
    let seconds = t0.elapsed().as_secs_f64();
    let written = a.out.write(dst, &map, &mask)?;
    let desc = format!("fisheye, {} {}°", a.model, a.fov);
    summary(
        &a.out,
        dst,
        &map,
        &report,
        &[desc],
        seconds,
        &written,
        &[&a.image],
    );
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn summary(
    out: &MapOut,
    dst: Mapping,
    map: &Image,
    r: &PhotoReport,
    models: &[String],
    seconds: f64,
    written: &[String],
    inputs: &[&str],
) {
    if out.job.json {
        let report = spheremap::jobs::photo::PhotoRunReport {
            inputs: inputs.iter().map(|i| i.to_string()).collect(),
            output: written.to_vec(),
            models: models.to_vec(),
            to: dst.name(),
            preset: dst.preset_name(),
            size: out.size,
            samples: out.sampling.samples,
            fill: out.fill,
            seconds,
            summary: r.summary(),
            losses: out.job.losses(map, &written[0], out.linear).into(),
        };
        crate::out_json(&report);
    } else if !out.job.quiet {
        for (i, (s, m)) in r.shots.iter().zip(models).enumerate() {
            let fit = match s.fit_rms {
                Some(rms) => format!(
                    "found, fit residual {rms:.3} px over {} edge points",
                    s.fit_points
                ),
                None => "given".into(),
            };
            let dist = if s.distance.is_finite() {
                format!(
                    "; ball {:.2} radii away, unseen cone behind it {:.2}°",
                    s.distance, s.blind_deg
                )
            } else {
                String::new()
            };
            eprintln!(
                "{}: {m}; ball at ({:.2}, {:.2}) r {:.2} px ({fit}){dist}",
                inputs[i], s.circle.cx, s.circle.cy, s.circle.r
            );
        }
        if let (Some(a), Some(g)) = (r.rotation_deg, r.gain) {
            let res = r.alignment_rms.map_or("not aligned".into(), |v| {
                format!("residual {v:.3} (log luminance)")
            });
            eprintln!("second shot: rotated {a:.2}° from the first, gain {g:.3}, {res}");
        }
        if r.shots.is_empty() {
            for m in models {
                eprintln!("{}: {m}", inputs[0]);
            }
        }
        let unseen = if r.seen_fraction < 1.0 && out.fill == Fill::None {
            " (unseen texels are 0; --fill smooth fills them)"
        } else {
            ""
        };
        eprintln!(
            "-> {} ({} {}): {:.1} % of the map seen{unseen}, {seconds:.3} s",
            written.join(", "),
            dst.name(),
            dst.preset_name(),
            100.0 * r.seen_fraction
        );
    }
}
