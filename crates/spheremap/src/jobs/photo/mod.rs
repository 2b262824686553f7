//! Sphere maps from photographs: a mirror ball (one or two shots, orthographic or perspective
//! camera) or a fisheye lens.
//!
//! Every route is the generator ([`crate::trace::generate`]) with a ray source that looks each
//! direction up in the photo(s): so the output is filtered over each texel's footprint (several
//! samples per texel, the same rules as `convert`), can be any mapping and any view, and has
//! the same gutter.  The source returns, per direction, the photos' colours weighted by their
//! **confidence**, the sum of the weights and the best confidence; after averaging over the
//! texel the colour is the weighted mean and the confidence is the mask.
//!
//! ## Confidence (the mask)
//!
//! For a mirror-ball shot: the cosine of the camera ray's incidence on the ball (1 at the
//! ball's centre, 0 at the grazing rim, where a texel of the map is smeared over a thin band
//! of the photo), times a ramp that is 0 within `camera_radius` of the direction back toward
//! the camera (where the camera and the photographer are reflected) and 1 beyond 1.5× that.
//! Directions a photo does not show have confidence 0.  For a fisheye: 1 inside the lens'
//! field of view and the image, 0 elsewhere.  The mask of a texel is the mean over its samples
//! of the best confidence among the shots.
//!
//! ## Two shots
//!
//! The second photo is taken from about `angle` degrees around the ball (positive: the
//! second camera stands to the first camera's right, a right-handed turn about the first
//! view's +Y).  The relative rotation starts there (both signs are tried) and is refined by
//! aligning the two photos' log luminance where both see well (Nelder–Mead over a rotation
//! vector, first on blurred lookups, then sharp; a luminance gain between the shots is
//! estimated at the same time and applied).  The blend weights are the confidences, so each
//! shot's camera region and its grazing rim band are taken from the other shot; where only
//! one shot sees, its colour is kept however low its confidence (a tiny floor on the weight).
//!
//! ## Holes
//!
//! Directions no photo sees are 0 with mask 0 by default; [`Fill::Smooth`] fills them by
//! pull-push interpolation from the seen texels (a smooth membrane across the hole, in the
//! output image), [`Fill::Mean`] with the mean colour of the seen texels.

mod ball;
mod circle;
mod exif;
mod find;
mod request;
mod rim;

pub use ball::{BallGeometry, BallModel, Located};
pub use circle::{find_circle, fit_circle, robust_circle, Circle, CircleFit};
pub use exif::{exif_hfov, FovSource};
pub use find::{find_ball_perspective, MIN_CONFIDENCE};
pub use request::{BallRequest, FisheyeRequest, Photo, PhotoOutput, Reflectance};
pub use rim::RimFit;

use crate::base::error::{Error, Result};
use crate::frame::view::{self, Mat3, IDENTITY};
use crate::images::Image;
use crate::mappings::fisheye::Lens;
use crate::mappings::mapping::Mapping;
use crate::resample::{Outside, Progress};
use crate::trace::generate::{
    centre_on_map, fill_outside, generate, GenerateOptions, RaySource, MAX_CHANNELS,
};

crate::base::named::named_enum! {
    /// What to put where no photo sees.
    #[derive(Default)]
    pub enum Fill: "fill" as "fill" {
        /// 0, with mask 0.
        #[default]
        None = "none",
        /// Pull-push interpolation from the seen texels.
        Smooth = "smooth",
        /// The mean colour of the seen texels.
        Mean = "mean",
    }
}

/// Options shared by the photo routes.
#[derive(Clone, Copy, Debug)]
pub struct PhotoOptions {
    pub mapping: Mapping,
    pub width: usize,
    pub height: usize,
    /// Samples, filter, gutter, view (`rotation`: output map frame → the first shot's view
    /// frame), seed, precision, memory limit.
    pub generate: GenerateOptions,
    /// The ball's reflectance per channel (the photo is divided by it); 1 for a fisheye.
    pub reflectance: [f32; 3],
    /// Radius (degrees) around the direction back to the camera whose confidence is 0.
    pub camera_radius_deg: f64,
    /// Starting angle (degrees) of the second shot around the ball.
    pub angle_deg: f64,
    /// Refine the second shot's rotation by alignment (else use `angle_deg` as is).
    pub align: bool,
    pub fill: Fill,
}

impl Default for PhotoOptions {
    fn default() -> Self {
        PhotoOptions {
            mapping: Mapping::Sphere(&crate::frame::conventions::PRESETS[0]),
            width: 512,
            height: 512,
            generate: GenerateOptions::default(),
            reflectance: [1.0; 3],
            camera_radius_deg: 20.0,
            angle_deg: 90.0,
            align: true,
            fill: Fill::None,
        }
    }
}

/// A mirror-ball photo and how it was taken.
#[derive(Clone, Copy, Debug)]
pub struct BallPhoto<'a> {
    pub image: &'a Image,
    pub model: BallModel,
    /// The ball's outline, when known (else it is found).
    pub circle: Option<Circle>,
}

/// How one shot was located.
#[derive(Clone, Debug)]
pub struct ShotReport {
    pub circle: Circle,
    /// RMS of the circle fit in pixels (`None` when the circle was given).
    pub fit_rms: Option<f64>,
    /// Edge points the fit kept.
    pub fit_points: usize,
    /// How sure the fit is, 0 to 1 ([`CircleFit::confidence`]; `None` when the circle was
    /// given).
    pub confidence: Option<f64>,
    /// The reflectance the perspective rim model saw.
    pub reflectance: Option<f64>,
    /// The perspective rim model's estimate of one standard deviation of the outline, in
    /// pixels ([`CircleFit::uncertainty`]).
    pub uncertainty: Option<f64>,
    /// Ball distance in radii (infinite for the orthographic model).
    pub distance: f64,
    /// Half-angle (degrees) of the unseen cone behind the ball.
    pub blind_deg: f64,
}

/// What a photo route did.
#[derive(Clone, Debug, Default)]
pub struct PhotoReport {
    pub shots: Vec<ShotReport>,
    /// Second shot: rotation from its view frame to the first one's (row-major) and its angle.
    pub rotation: Option<Mat3>,
    pub rotation_deg: Option<f64>,
    /// RMS log-luminance difference of the two shots where both see well, after alignment.
    pub alignment_rms: Option<f64>,
    /// Gain applied to the second shot.
    pub gain: Option<f64>,
    /// Fraction of the output's texels (those on the map) that some photo sees.
    pub seen_fraction: f64,
    pub rays: u64,
}

/// A photo route's report as `spheremap from-photo --json` prints it and Python's
/// `from_mirror_ball` / `from_fisheye` return it (their third value): one shape for both.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PhotoSummary {
    pub shots: Vec<ShotSummary>,
    /// Second shot: rotation from its view frame to the first one's (row-major), its angle,
    /// the alignment's RMS log-luminance residual and the gain applied to it.
    pub rotation: Option<Mat3>,
    pub rotation_deg: Option<f64>,
    pub alignment_rms: Option<f64>,
    pub gain: Option<f64>,
    /// Fraction of the output's texels that some photo sees.
    pub seen_fraction: f64,
    /// Samples (rays) taken in all.
    pub samples_total: u64,
}

/// The report of `spheremap from-photo` and `from-fisheye --json`: the files read and
/// written, each photo's model, the output's mapping, size, samples and fill, the
/// [`PhotoSummary`] and what writing the map lost.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PhotoRunReport {
    pub inputs: Vec<String>,
    pub output: Vec<String>,
    pub models: Vec<String>,
    pub to: &'static str,
    pub preset: &'static str,
    pub size: usize,
    pub samples: u32,
    pub fill: Fill,
    pub seconds: f64,
    #[serde(flatten)]
    pub summary: PhotoSummary,
    #[serde(flatten)]
    pub losses: crate::images::codec::LossCounts,
}

/// One mirror-ball shot in a [`PhotoSummary`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ShotSummary {
    /// The ball's outline (cx, cy, r) in pixels.
    pub circle: [f64; 3],
    /// RMS of the circle fit (`None` when the circle was given); `fit_rms_px` is the same for
    /// the edge fit, in pixels, and `None` for the rim model (whose residual is of luminance).
    pub fit_rms: Option<f64>,
    pub fit_rms_px: Option<f64>,
    pub fit_points: usize,
    pub confidence: Option<f64>,
    pub reflectance: Option<f64>,
    pub uncertainty_px: Option<f64>,
    /// Ball distance in radii (`None` for the orthographic model) and the half-angle of the
    /// unseen cone behind the ball.
    pub distance_radii: Option<f64>,
    pub blind_cone_deg: f64,
}

impl PhotoReport {
    /// The report as users read it.
    pub fn summary(&self) -> PhotoSummary {
        PhotoSummary {
            shots: self
                .shots
                .iter()
                .map(|s| ShotSummary {
                    circle: [s.circle.cx, s.circle.cy, s.circle.r],
                    fit_rms: s.fit_rms,
                    fit_rms_px: s.fit_rms.filter(|_| s.reflectance.is_none()),
                    fit_points: s.fit_points,
                    confidence: s.confidence,
                    reflectance: s.reflectance,
                    uncertainty_px: s.uncertainty,
                    distance_radii: s.distance.is_finite().then_some(s.distance),
                    blind_cone_deg: s.blind_deg,
                })
                .collect(),
            rotation: self.rotation,
            rotation_deg: self.rotation_deg,
            alignment_rms: self.alignment_rms,
            gain: self.gain,
            seen_fraction: self.seen_fraction,
            samples_total: self.rays,
        }
    }
}

/// A photo's lens: a located mirror ball or a fisheye.
#[derive(Clone, Copy, Debug)]
#[allow(clippy::large_enum_variant)] // one or two per job
enum Projector {
    Ball(BallGeometry),
    Lens(Lens),
}

impl Projector {
    fn locate(&self, d: [f64; 3]) -> Option<Located> {
        match self {
            Projector::Ball(b) => b.locate(d),
            Projector::Lens(l) => l.dir_to_pixel(d).map(|pixel| Located {
                pixel,
                quality: 1.0,
            }),
        }
    }
}

/// One photo as seen from the output's frame.
struct ShotView<'a> {
    image: &'a Image,
    projector: Projector,
    /// Output frame (the first shot's view) → this shot's view frame.
    to_shot: Mat3,
    /// Per channel: 1/reflectance × gain.
    scale: [f32; 4],
    /// Cosines of the camera exclusion's inner and outer angles (mirror balls).
    exclusion: Option<(f64, f64)>,
}

fn mat_vec(m: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

/// Bilinear lookup at a continuous pixel position, edge-clamped; `false` off the image.
fn bilinear(img: &Image, p: [f64; 2], out: &mut [f32]) -> bool {
    let (w, h) = (img.width as f64, img.height as f64);
    if !(p[0] >= 0.0 && p[1] >= 0.0 && p[0] <= w && p[1] <= h) {
        return false;
    }
    let fx = (p[0] - 0.5).clamp(0.0, w - 1.0);
    let fy = (p[1] - 0.5).clamp(0.0, h - 1.0);
    let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(img.width - 1), (y0 + 1).min(img.height - 1));
    let (ax, ay) = ((fx - x0 as f64) as f32, (fy - y0 as f64) as f32);
    let c = img.channels;
    for k in 0..c {
        let v = |x: usize, y: usize| img.data[(y * img.width + x) * c + k];
        out[k] = (v(x0, y0) * (1.0 - ax) + v(x1, y0) * ax) * (1.0 - ay)
            + (v(x0, y1) * (1.0 - ax) + v(x1, y1) * ax) * ay;
    }
    true
}

fn smoothstep(e0: f64, e1: f64, x: f64) -> f64 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl ShotView<'_> {
    /// Colour (scaled), blend weight and confidence of a unit output-frame direction.
    fn look(&self, d: [f64; 3], colour: &mut [f32]) -> Option<(f64, f64)> {
        let ds = mat_vec(&self.to_shot, d);
        let loc = self.projector.locate(ds)?;
        if !bilinear(self.image, loc.pixel, colour) {
            return None;
        }
        for (v, s) in colour.iter_mut().zip(self.scale) {
            *v *= s;
        }
        // The direction back toward the camera is the view frame's +Z.
        let cam = self
            .exclusion
            .map_or(1.0, |(cos_in, cos_out)| smoothstep(cos_in, cos_out, ds[2]));
        let conf = loc.quality * cam;
        Some((conf.max(1e-4 * loc.quality.max(1e-3)), conf))
    }
}

/// The photos as a ray source: channels = colour (premultiplied by weight), weight sum, best
/// confidence.
struct PhotoSource<'a> {
    shots: Vec<ShotView<'a>>,
    colour: usize,
}

impl RaySource for PhotoSource<'_> {
    fn channels(&self) -> usize {
        self.colour + 2
    }
    fn trace(&self, _: &[[f32; 3]], directions: &[[f32; 3]], out: &mut [f32]) -> Result<()> {
        let c = self.colour;
        let mut px = [0f32; 4];
        for (d, o) in directions.iter().zip(out.chunks_exact_mut(c + 2)) {
            o.fill(0.0);
            let d = d.map(|v| v as f64);
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let d = d.map(|v| v / l);
            let mut best = 0f64;
            for s in &self.shots {
                if let Some((w, conf)) = s.look(d, &mut px[..c]) {
                    for k in 0..c {
                        o[k] += w as f32 * px[k];
                    }
                    o[c] += w as f32;
                    best = best.max(conf);
                }
            }
            o[c + 1] = best as f32;
        }
        Ok(())
    }
}

fn check_photo(img: &Image, what: &str) -> Result<()> {
    if !(1..=MAX_CHANNELS - 2).contains(&img.channels) || img.channels > 4 {
        return Err(Error::param(
            what,
            format!("has {} channels; 1 to 4 are supported", img.channels),
        ));
    }
    if img.width < 2 || img.height < 2 {
        return Err(Error::param(what, "is smaller than 2×2"));
    }
    Ok(())
}

/// Locates the ball of one photo.
fn locate_ball(photo: &BallPhoto, what: &str) -> Result<(BallGeometry, ShotReport)> {
    check_photo(photo.image, what)?;
    let fit = match photo.circle {
        Some(c) => {
            if !(c.r > 0.0 && c.cx.is_finite() && c.cy.is_finite() && c.r.is_finite()) {
                return Err(Error::param(
                    "circle",
                    "needs a finite centre and a positive radius",
                ));
            }
            None
        }
        // A perspective photo's ball by the rim model, an orthographic one's by the edge fit.
        None => Some(
            match photo.model {
                BallModel::Perspective { hfov_deg } => find_ball_perspective(photo.image, hfov_deg),
                BallModel::Orthographic => find_circle(photo.image, None),
            }
            .map_err(|e| e.renamed("image", what))?,
        ),
    };
    let circle = fit
        .as_ref()
        .map_or_else(|| photo.circle.unwrap(), |f| f.circle);
    let geom = match photo.model {
        BallModel::Orthographic => BallGeometry::orthographic(circle)?,
        BallModel::Perspective { hfov_deg } => {
            let outline: Vec<[f64; 2]> = match &fit {
                Some(f) => f.points.clone(),
                None => (0..64)
                    .map(|k| {
                        let t = k as f64 * std::f64::consts::TAU / 64.0;
                        [
                            circle.cx + circle.r * t.cos(),
                            circle.cy + circle.r * t.sin(),
                        ]
                    })
                    .collect(),
            };
            BallGeometry::perspective(&outline, hfov_deg, photo.image.width, photo.image.height)
                .map_err(|e| e.renamed("image", what))?
        }
    };
    let report = ShotReport {
        circle: geom.circle,
        fit_rms: fit.as_ref().map(|f| f.rms),
        fit_points: fit.as_ref().map_or(0, |f| f.points.len()),
        confidence: fit.as_ref().map(|f| f.confidence),
        reflectance: fit.as_ref().and_then(|f| f.reflectance),
        uncertainty: fit.as_ref().and_then(|f| f.uncertainty),
        distance: geom.distance,
        blind_deg: geom.blind_half_angle().to_degrees(),
    };
    Ok((geom, report))
}

/// A ball's reflectance per channel, checked: positive and finite (at most 10⁶).
pub(crate) fn check_reflectance(v: [f32; 3]) -> Result<[f32; 3]> {
    if v.iter().all(|&r| r > 0.0 && r <= 1e6) {
        Ok(v)
    } else {
        Err(Error::param(
            "reflectance",
            format!("must be positive and finite, got {v:?}"),
        ))
    }
}

/// The radius in degrees around the direction back to the camera whose confidence is 0,
/// checked: in [0°, 90°).
pub(crate) fn check_camera_radius(deg: f64) -> Result<f64> {
    if (0.0..90.0).contains(&deg) {
        Ok(deg)
    } else {
        Err(Error::param("camera_radius", "must be in [0°, 90°)"))
    }
}

fn scale_of(reflectance: [f32; 3], channels: usize, gain: f64) -> Result<[f32; 4]> {
    check_reflectance(reflectance)?;
    let mut s = [gain as f32; 4];
    for k in 0..channels.min(3) {
        s[k] /= if channels < 3 {
            (reflectance[0] + reflectance[1] + reflectance[2]) / 3.0
        } else {
            reflectance[k]
        };
    }
    Ok(s)
}

/// A sphere map (or any mapping) from one or two mirror-ball photos, with its confidence
/// mask (one channel) and a report.
pub fn from_mirror_ball(
    first: &BallPhoto,
    second: Option<&BallPhoto>,
    opts: &PhotoOptions,
    progress: Option<&Progress>,
) -> Result<(Image, Image, PhotoReport)> {
    check_camera_radius(opts.camera_radius_deg)?;
    let (g1, r1) = locate_ball(first, "photo")?;
    let exclusion = (opts.camera_radius_deg > 0.0).then(|| {
        let a = opts.camera_radius_deg.to_radians();
        (a.cos(), (1.5 * a).min(std::f64::consts::FRAC_PI_2).cos())
    });
    let c = first.image.channels;
    let mut report = PhotoReport {
        shots: vec![r1],
        ..Default::default()
    };
    let mut shots = vec![ShotView {
        image: first.image,
        projector: Projector::Ball(g1),
        to_shot: IDENTITY,
        scale: scale_of(opts.reflectance, c, 1.0)?,
        exclusion,
    }];
    if let Some(p2) = second {
        if p2.image.channels != c {
            return Err(Error::param(
                "second",
                format!("has {} channels, the first photo {c}", p2.image.channels),
            ));
        }
        if !opts.angle_deg.is_finite() {
            return Err(Error::param("angle", "must be finite"));
        }
        let (g2, r2) = locate_ball(p2, "second")?;
        report.shots.push(r2);
        let mut s2 = ShotView {
            image: p2.image,
            projector: Projector::Ball(g2),
            to_shot: ry(-opts.angle_deg),
            scale: scale_of(opts.reflectance, c, 1.0)?,
            exclusion,
        };
        let (to_shot, rms, gain) = if opts.align {
            align::align(&shots[0], &s2, opts.angle_deg)?
        } else {
            (ry(-opts.angle_deg), f64::NAN, 1.0)
        };
        s2.to_shot = to_shot;
        s2.scale = scale_of(opts.reflectance, c, gain)?;
        let r21 = view::transpose(&to_shot);
        report.rotation = Some(r21);
        report.rotation_deg = Some(rotation_angle(&r21).to_degrees());
        report.alignment_rms = rms.is_finite().then_some(rms);
        report.gain = Some(gain);
        shots.push(s2);
    }
    run(shots, c, opts, progress, report)
}

/// A sphere map (or any mapping) of the camera's view from a fisheye photo, with its coverage
/// mask.
pub fn from_fisheye(
    image: &Image,
    lens: Lens,
    opts: &PhotoOptions,
    progress: Option<&Progress>,
) -> Result<(Image, Image, PhotoReport)> {
    check_photo(image, "image")?;
    let c = image.channels;
    let shots = vec![ShotView {
        image,
        projector: Projector::Lens(lens),
        to_shot: IDENTITY,
        scale: scale_of(opts.reflectance, c, 1.0)?,
        exclusion: None,
    }];
    run(shots, c, opts, progress, PhotoReport::default())
}

fn run(
    shots: Vec<ShotView>,
    c: usize,
    opts: &PhotoOptions,
    progress: Option<&Progress>,
    mut report: PhotoReport,
) -> Result<(Image, Image, PhotoReport)> {
    let source = PhotoSource { shots, colour: c };
    // Rim samples off a disc add weight 0 (black); the gutter is made from the finished map.
    let gopts = GenerateOptions {
        outside: Outside::Black,
        ..opts.generate
    };
    let (raw, g) = generate(
        opts.mapping,
        opts.width,
        opts.height,
        &source,
        &gopts,
        progress,
    )?;
    report.rays = g.rays;
    let (w, h) = (raw.width, raw.height);
    let mut map = Image::new(w, h, c);
    let mut mask = Image::new(w, h, 1);
    let mut known = vec![false; w * h];
    for (i, px) in raw.data.chunks_exact(c + 2).enumerate() {
        let wsum = px[c];
        if wsum > 0.0 {
            for k in 0..c {
                map.data[i * c + k] = px[k] / wsum;
            }
            known[i] = true;
        }
        mask.data[i] = px[c + 1].clamp(0.0, 1.0);
    }
    let on_map: Vec<bool> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| centre_on_map(opts.mapping, w, h, x, y))
        .collect();
    let seen = known
        .iter()
        .zip(&on_map)
        .filter(|(k, o)| **k && **o)
        .count();
    report.seen_fraction = seen as f64 / on_map.iter().filter(|o| **o).count().max(1) as f64;
    match opts.fill {
        Fill::None => {}
        Fill::Mean => fill::mean(&mut map, &known, &on_map),
        Fill::Smooth => fill::pull_push(&mut map, &known),
    }
    if opts.mapping.has_outside() {
        fill_outside(
            opts.mapping,
            &mut map,
            opts.generate.outside,
            opts.generate.samples == 1,
        );
        for (m, o) in mask.data.iter_mut().zip(&on_map) {
            if !o {
                *m = 0.0;
            }
        }
    }
    Ok((map, mask, report))
}

/// Rotation about +Y by `deg` degrees (row-major).
fn ry(deg: f64) -> Mat3 {
    let (s, c) = deg.to_radians().sin_cos();
    [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
}

fn rotation_angle(r: &Mat3) -> f64 {
    (0.5 * (r[0][0] + r[1][1] + r[2][2] - 1.0))
        .clamp(-1.0, 1.0)
        .acos()
}

mod fill {
    use crate::images::Image;

    /// Unknown texels get the mean of the known ones on the map.
    pub fn mean(map: &mut Image, known: &[bool], on_map: &[bool]) {
        let c = map.channels;
        let mut sum = vec![0f64; c];
        let mut n = 0usize;
        for (i, px) in map.data.chunks_exact(c).enumerate() {
            if known[i] && on_map[i] {
                for k in 0..c {
                    sum[k] += px[k] as f64;
                }
                n += 1;
            }
        }
        if n == 0 {
            return;
        }
        for (i, px) in map.data.chunks_exact_mut(c).enumerate() {
            if !known[i] {
                for k in 0..c {
                    px[k] = (sum[k] / n as f64) as f32;
                }
            }
        }
    }

    /// Pull-push: average the known texels down a pyramid (weights = known), then fill each
    /// unknown texel from the next coarser level (bilinear), coarse to fine.
    pub fn pull_push(map: &mut Image, known: &[bool]) {
        let c = map.channels;
        // Level 0: premultiplied values and weights.
        let mut levels: Vec<(usize, usize, Vec<f32>, Vec<f32>)> = vec![(
            map.width,
            map.height,
            map.data
                .chunks_exact(c)
                .zip(known)
                .flat_map(|(p, &k)| p.iter().map(move |v| if k { *v } else { 0.0 }))
                .collect(),
            known.iter().map(|&k| k as u8 as f32).collect(),
        )];
        while {
            let (w, h, _, _) = &levels[levels.len() - 1];
            *w > 1 || *h > 1
        } {
            let (w, h, v, wt) = &levels[levels.len() - 1];
            let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
            let mut nv = vec![0f32; nw * nh * c];
            let mut nwt = vec![0f32; nw * nh];
            for y in 0..*h {
                for x in 0..*w {
                    let (i, j) = (y * w + x, (y / 2) * nw + x / 2);
                    nwt[j] += wt[i];
                    for k in 0..c {
                        nv[j * c + k] += v[i * c + k];
                    }
                }
            }
            // Normalise to weight ≤ 1 (a mean), keeping premultiplication.
            for j in 0..nw * nh {
                if nwt[j] > 1.0 {
                    let s = 1.0 / nwt[j];
                    for k in 0..c {
                        nv[j * c + k] *= s;
                    }
                    nwt[j] = 1.0;
                }
            }
            levels.push((nw, nh, nv, nwt));
        }
        // Push: coarse to fine, each level's texels become (value + (1 − weight) × coarse).
        for l in (0..levels.len() - 1).rev() {
            let (cw, ch, cv, _) = levels[l + 1].clone();
            let (w, h, v, wt) = &mut levels[l];
            for y in 0..*h {
                for x in 0..*w {
                    let i = y * *w + x;
                    if wt[i] >= 1.0 {
                        continue;
                    }
                    // Bilinear in the coarse level (texel centres at (i + ½) · 2).
                    let fx = ((x as f32 + 0.5) / 2.0 - 0.5).clamp(0.0, (cw - 1) as f32);
                    let fy = ((y as f32 + 0.5) / 2.0 - 0.5).clamp(0.0, (ch - 1) as f32);
                    let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
                    let (x1, y1) = ((x0 + 1).min(cw - 1), (y0 + 1).min(ch - 1));
                    let (ax, ay) = (fx - x0 as f32, fy - y0 as f32);
                    let a = 1.0 - wt[i];
                    for k in 0..c {
                        let s = |xx: usize, yy: usize| cv[(yy * cw + xx) * c + k];
                        let coarse = (s(x0, y0) * (1.0 - ax) + s(x1, y0) * ax) * (1.0 - ay)
                            + (s(x0, y1) * (1.0 - ax) + s(x1, y1) * ax) * ay;
                        v[i * c + k] += a * coarse;
                    }
                    wt[i] = 1.0;
                }
            }
        }
        for (i, px) in map.data.chunks_exact_mut(c).enumerate() {
            if !known[i] {
                px.copy_from_slice(&levels[0].2[i * c..(i + 1) * c]);
            }
        }
    }
}

mod align {
    //! The second shot's rotation by aligning the photos (see the module docs).
    use super::*;

    /// Directions spread evenly over the sphere (Fibonacci lattice).
    fn fibonacci(n: usize) -> Vec<[f64; 3]> {
        let g = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let a = g * i as f64;
                [r * a.cos(), r * a.sin(), z]
            })
            .collect()
    }

    /// Rodrigues: the rotation by the rotation vector `w`.
    pub(super) fn exp(w: [f64; 3]) -> Mat3 {
        let t = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        if t < 1e-15 {
            return IDENTITY;
        }
        let k = w.map(|v| v / t);
        let (s, c) = t.sin_cos();
        let mut m = IDENTITY;
        let kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] = if i == j { c } else { 0.0 } + s * kx[i][j] + (1.0 - c) * k[i] * k[j];
            }
        }
        m
    }

    fn log_lum(px: &[f32]) -> f64 {
        let l = if px.len() >= 3 {
            0.2126 * px[0] + 0.7152 * px[1] + 0.0722 * px[2]
        } else {
            px[0]
        };
        (l.max(0.0) as f64 + 1e-3).ln()
    }

    /// Log luminance blurred by `blur` pixels (five bilinear taps) and the confidence, for a
    /// unit direction in the shot's own view frame.
    fn probe(s: &ShotView, ds: [f64; 3], blur: f64) -> Option<(f64, f64)> {
        let loc = s.projector.locate(ds)?;
        let cam = s
            .exclusion
            .map_or(1.0, |(_, cos_out)| if ds[2] >= cos_out { 0.0 } else { 1.0 });
        let conf = loc.quality * cam;
        if conf < 0.3 {
            return None;
        }
        let mut px = [0f32; 4];
        let mut sum = 0.0;
        for (dx, dy) in [
            (0.0, 0.0),
            (blur, 0.0),
            (-blur, 0.0),
            (0.0, blur),
            (0.0, -blur),
        ] {
            if !bilinear(s.image, [loc.pixel[0] + dx, loc.pixel[1] + dy], &mut px) {
                return None;
            }
            sum += log_lum(&px[..s.image.channels]);
        }
        Some((sum / 5.0, conf))
    }

    /// Robust cost of a rotation (output frame → second shot) and the mean log difference.
    fn cost(
        dirs: &[[f64; 3]],
        first: &[Option<f64>],
        second: &ShotView,
        to_shot: &Mat3,
        blur: f64,
    ) -> (f64, f64, f64) {
        let mut diffs = Vec::with_capacity(dirs.len());
        for (d, l1) in dirs.iter().zip(first) {
            let Some(l1) = l1 else { continue };
            if let Some((l2, _)) = probe(second, mat_vec(to_shot, *d), blur) {
                diffs.push(l1 - l2);
            }
        }
        if diffs.len() < 100 {
            return (1e3 - diffs.len() as f64, 0.0, f64::NAN);
        }
        let mut sorted = diffs.clone();
        sorted.sort_by(|a, b| a.total_cmp(b));
        let m = sorted[sorted.len() / 2];
        let trunc =
            diffs.iter().map(|d| (d - m).powi(2).min(0.25)).sum::<f64>() / diffs.len() as f64;
        let rms = (diffs.iter().map(|d| (d - m).powi(2)).sum::<f64>() / diffs.len() as f64).sqrt();
        (trunc, m, rms)
    }

    /// Nelder–Mead over a rotation vector applied after `base`.
    fn minimise(f: &dyn Fn(&Mat3) -> f64, base: Mat3, step: f64, iters: usize) -> (Mat3, f64) {
        let at = |w: [f64; 3]| view::mul(&exp(w), &base);
        let mut simplex: Vec<([f64; 3], f64)> = vec![([0.0; 3], 0.0)];
        for i in 0..3 {
            let mut w = [0.0; 3];
            w[i] = step;
            simplex.push((w, 0.0));
        }
        let mut simplex: Vec<([f64; 3], f64)> =
            simplex.into_iter().map(|(w, _)| (w, f(&at(w)))).collect();
        for _ in 0..iters {
            simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
            let centroid =
                [0, 1, 2].map(|k| simplex[..3].iter().map(|s| s.0[k]).sum::<f64>() / 3.0);
            let worst = simplex[3];
            let along = |t: f64| [0, 1, 2].map(|k| centroid[k] + t * (worst.0[k] - centroid[k]));
            let r = along(-1.0);
            let fr = f(&at(r));
            if fr < simplex[0].1 {
                let e = along(-2.0);
                let fe = f(&at(e));
                simplex[3] = if fe < fr { (e, fe) } else { (r, fr) };
            } else if fr < simplex[2].1 {
                simplex[3] = (r, fr);
            } else {
                let k = along(0.5);
                let fk = f(&at(k));
                if fk < worst.1 {
                    simplex[3] = (k, fk);
                } else {
                    let best = simplex[0].0;
                    for s in simplex.iter_mut().skip(1) {
                        s.0 = [0, 1, 2].map(|k| best[k] + 0.5 * (s.0[k] - best[k]));
                        s.1 = f(&at(s.0));
                    }
                }
            }
            let spread = simplex
                .iter()
                .map(|s| {
                    (0..3)
                        .map(|k| (s.0[k] - simplex[0].0[k]).abs())
                        .fold(0.0, f64::max)
                })
                .fold(0.0, f64::max);
            if spread < 1e-5 {
                break;
            }
        }
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        (at(simplex[0].0), simplex[0].1)
    }

    /// The rotation (output frame → second shot), the residual and the gain.
    pub fn align(first: &ShotView, second: &ShotView, angle_deg: f64) -> Result<(Mat3, f64, f64)> {
        let dirs = fibonacci(6000);
        let radius = |s: &ShotView| match s.projector {
            Projector::Ball(b) => b.circle.r,
            Projector::Lens(l) => l.radius_px,
        };
        let (r1, r2) = (radius(first), radius(second));
        let mut best: Option<(Mat3, f64)> = None;
        for (blur_div, step_deg, iters) in [(25.0, 6.0f64, 80), (100.0, 1.5, 120)] {
            let (b1, b2) = ((r1 / blur_div).max(0.5), (r2 / blur_div).max(0.5));
            let l1: Vec<Option<f64>> = dirs
                .iter()
                .map(|d| probe(first, *d, b1).map(|p| p.0))
                .collect();
            let f = |m: &Mat3| cost(&dirs, &l1, second, m, b2).0;
            let starts = match best {
                None => vec![ry(-angle_deg), ry(angle_deg)],
                Some((m, _)) => vec![m],
            };
            best = starts
                .into_iter()
                .map(|m| minimise(&f, m, step_deg.to_radians(), iters))
                .min_by(|a, b| a.1.total_cmp(&b.1));
        }
        let (m, c) = best.expect("candidates");
        if c >= 1e2 {
            return Err(Error::data(
                "second",
                "the two photos do not overlap enough to align them (is --angle right?)",
            ));
        }
        let l1: Vec<Option<f64>> = dirs
            .iter()
            .map(|d| probe(first, *d, 0.5).map(|p| p.0))
            .collect();
        let (_, mean, rms) = cost(&dirs, &l1, second, &m, 0.5);
        Ok((m, rms, mean.exp()))
    }
}

impl crate::jobs::Report for PhotoRunReport {
    /// A line per photo (its model, the ball found or given, its distance and unseen cone),
    /// the second shot's rotation, gain and alignment, and the map written.
    fn lines(&self) -> Vec<String> {
        let (r, s) = (self, &self.summary);
        let mut o = Vec::new();
        for (i, (shot, m)) in s.shots.iter().zip(&r.models).enumerate() {
            let fit = match shot.fit_rms {
                Some(rms) => format!(
                    "found, fit residual {rms:.3} px over {} edge points",
                    shot.fit_points
                ),
                None => "given".into(),
            };
            let dist = shot.distance_radii.map_or(String::new(), |d| {
                format!(
                    "; ball {d:.2} radii away, unseen cone behind it {:.2}°",
                    shot.blind_cone_deg
                )
            });
            let [cx, cy, rad] = shot.circle;
            o.push(format!(
                "{}: {m}; ball at ({cx:.2}, {cy:.2}) r {rad:.2} px ({fit}){dist}",
                r.inputs[i]
            ));
        }
        if let (Some(a), Some(g)) = (s.rotation_deg, s.gain) {
            let res = s.alignment_rms.map_or("not aligned".into(), |v| {
                format!("residual {v:.3} (log luminance)")
            });
            o.push(format!(
                "second shot: rotated {a:.2}° from the first, gain {g:.3}, {res}"
            ));
        }
        if s.shots.is_empty() {
            for m in &r.models {
                o.push(format!("{}: {m}", r.inputs[0]));
            }
        }
        let unseen = if s.seen_fraction < 1.0 && r.fill == Fill::None {
            " (unseen texels are 0; --fill smooth fills them)"
        } else {
            ""
        };
        o.push(format!(
            "-> {} ({} {}): {:.1} % of the map seen{unseen}, {:.3} s",
            r.output.join(", "),
            r.to,
            r.preset,
            100.0 * s.seen_fraction,
            r.seconds
        ));
        o
    }
}
