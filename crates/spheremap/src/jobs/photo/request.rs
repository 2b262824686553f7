//! The photo routes as requests: [`BallRequest`] (`spheremap from-photo`, Python's
//! `from_mirror_ball`) and [`FisheyeRequest`] (`spheremap from-fisheye`, `from_fisheye`) hold
//! what users name, with the documented defaults (`Default`) and every check (`resolve`), and
//! run on files (`run_files`: read, unwarp, write, report) or on photos already in memory
//! (`run`).  The output side is the generator's [`MapRequest`], flattened in: `to`, `preset`,
//! `layout`, `size`, `look`, `up`, `samples`, `max_samples`, `filter`, `outside`, `seed`,
//! `precision`, `max_memory`.

use super::{
    exif_hfov, from_fisheye, from_mirror_ball, BallModel, BallPhoto, Circle, Fill, FovSource,
    PhotoOptions, PhotoReport, PhotoRunReport, PhotoSummary,
};
use crate::base::error::{Error, Result};
use crate::images::codec::{
    check_nonfinite, decode_file, Losses, NonFinite, ReadOptions, WriteOptions,
};
use crate::images::envmap::{refuse_overwrite, write_env, EnvFiles};
use crate::images::format::Format;
use crate::images::Image;
use crate::mappings::fisheye::{Lens, LensModel, LensName};
use crate::resample::Progress;
use crate::trace::generate::{MapRequest, ResolvedMap};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A ball's reflectance: one value for every channel, or one per channel (R, G, B).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Reflectance {
    Grey(f32),
    Rgb(Vec<f32>),
}

impl Reflectance {
    /// Per channel; one value or three, each positive and finite.
    pub fn rgb(&self) -> Result<[f32; 3]> {
        let v = match self {
            Reflectance::Grey(r) => [*r; 3],
            Reflectance::Rgb(v) if v.len() == 1 => [v[0]; 3],
            Reflectance::Rgb(v) if v.len() == 3 => [v[0], v[1], v[2]],
            Reflectance::Rgb(v) => {
                return Err(Error::param(
                    "reflectance",
                    format!("give one value or three (R G B), not {}", v.len()),
                ))
            }
        };
        super::check_reflectance(v)
    }
}

/// A photo in memory: its texels, the bytes of its file (for EXIF; `None` for an array) and
/// the name its errors use (the file's path, or the argument's name).
#[derive(Clone, Debug)]
pub struct Photo {
    pub image: Image,
    pub exif: Option<Vec<u8>>,
    pub name: String,
}

impl Photo {
    /// The photo in the file `path`: read with `linear` (LDR files as linear values), NaN
    /// and Inf treated by `nonfinite`, its bytes kept for EXIF.
    pub fn read(path: &str, linear: bool, nonfinite: NonFinite) -> Result<Photo> {
        let p = Path::new(path);
        let bytes = crate::base::files::read_file(p)?;
        let opts = ReadOptions {
            linear,
            ..Default::default()
        };
        let mut image = decode_file(p, &bytes, &opts)?;
        check_nonfinite(&mut image, nonfinite, path)?;
        Ok(Photo {
            image,
            exif: Some(bytes),
            name: path.to_string(),
        })
    }

    /// An error the unwarp gives of its argument `arg`, said of this photo: of its file (as
    /// bad data in it), or of the argument the caller names it by.
    fn own(&self, e: Error, arg: &str) -> Error {
        match e {
            Error::InvalidParameter { name, reason } if name == arg && self.exif.is_some() => {
                Error::data(&self.name, reason)
            }
            e => e.renamed(arg, &self.name),
        }
    }

    /// A photo given as texels (`name`: the argument), NaN and Inf treated by `nonfinite`.
    pub fn texels(mut image: Image, name: &str, nonfinite: NonFinite) -> Result<Photo> {
        check_nonfinite(&mut image, nonfinite, name)?;
        Ok(Photo {
            image,
            exif: None,
            name: name.to_string(),
        })
    }
}

/// The mirror-ball route as users ask for it.  `Default` gives every documented default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BallRequest {
    /// Where the second camera stood, in degrees around the ball from the first (positive: to
    /// the first camera's right), and whether alignment refines it.
    pub angle: f64,
    pub align: bool,
    /// The photos' horizontal field of view in degrees, or focal length and sensor width in
    /// mm (default: the file's EXIF); or the orthographic camera.
    pub fov: Option<f64>,
    pub focal: Option<f64>,
    pub sensor: Option<f64>,
    pub orthographic: bool,
    /// Each photo's ball outline (cx, cy, r) in continuous pixel coordinates (default: found).
    pub circle: Option<[f64; 3]>,
    pub circle2: Option<[f64; 3]>,
    /// The ball's reflectance (default 1): the photo is divided by it.
    pub reflectance: Option<Reflectance>,
    /// Degrees around the direction back to the camera given confidence 0.
    pub camera_radius: f64,
    /// What to put where no photo sees.
    pub fill: Fill,
    /// LDR files read and written as linear values; NaN/Inf in a photo.
    pub linear: bool,
    pub nonfinite: NonFinite,
    /// The output map.
    #[serde(flatten)]
    pub map: MapRequest,
}

impl Default for BallRequest {
    fn default() -> Self {
        let o = PhotoOptions::default();
        BallRequest {
            angle: o.angle_deg,
            align: o.align,
            fov: None,
            focal: None,
            sensor: None,
            orthographic: false,
            circle: None,
            circle2: None,
            reflectance: None,
            camera_radius: o.camera_radius_deg,
            fill: o.fill,
            linear: false,
            nonfinite: NonFinite::default(),
            map: MapRequest::default(),
        }
    }
}

/// The fisheye route as users ask for it: `model` and `fov` are required.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FisheyeRequest {
    /// The lens model and its field of view across the image circle, in degrees.
    pub model: Option<LensName>,
    pub fov: Option<f64>,
    /// The optical centre (cx, cy) in continuous pixel coordinates (default: the image's
    /// centre) and the image circle's radius in pixels (default: half the shorter side).
    pub centre: Option<[f64; 2]>,
    pub radius: Option<f64>,
    /// The polynomial model's (k1, k2, k3, k4).
    pub k: Option<[f64; 4]>,
    pub fill: Fill,
    pub linear: bool,
    pub nonfinite: NonFinite,
    #[serde(flatten)]
    pub map: MapRequest,
}

/// What a photo route returns: the map, its confidence mask, the report and each photo's
/// camera as [`FovSource`] found it (`None`: orthographic, or a fisheye).
pub struct PhotoOutput {
    pub map: Image,
    pub mask: Image,
    pub report: PhotoReport,
    pub models: Vec<String>,
    pub fovs: Vec<Option<(f64, FovSource)>>,
}

/// A finite number, or an error naming `name`.
fn finite(name: &str, v: f64) -> Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::param(name, format!("must be finite, got {v}")))
    }
}

/// The output side, checked; the photo routes start no rays from a point.
fn resolve_map(map: &MapRequest) -> Result<ResolvedMap> {
    if map.pos != [0.0; 3] {
        return Err(Error::param(
            "pos",
            "the photo routes fire no rays from a point (the map is the camera's view)",
        ));
    }
    map.resolve()
}

fn photo_options(map: &ResolvedMap, fill: Fill) -> PhotoOptions {
    PhotoOptions {
        mapping: map.mapping,
        width: map.width,
        height: map.height,
        generate: map.options,
        fill,
        ..Default::default()
    }
}

impl BallRequest {
    /// Every field checked (errors name the field), as the unwarp's options.
    pub fn resolve(&self) -> Result<(PhotoOptions, ResolvedMap)> {
        let map = resolve_map(&self.map)?;
        for (name, v) in [
            ("fov", self.fov),
            ("focal", self.focal),
            ("sensor", self.sensor),
        ] {
            if let Some(v) = v {
                finite(name, v)?;
            }
        }
        if self.orthographic && (self.fov.is_some() || self.focal.is_some()) {
            return Err(Error::param(
                "orthographic",
                "an orthographic camera has no field of view: give one or the other",
            ));
        }
        for (name, c) in [("circle", self.circle), ("circle2", self.circle2)] {
            if let Some([cx, cy, r]) = c {
                if !(cx.is_finite() && cy.is_finite() && r.is_finite() && r > 0.0) {
                    return Err(Error::param(
                        name,
                        format!(
                            "needs a finite centre and a positive radius, got ({cx}, {cy}, {r})"
                        ),
                    ));
                }
            }
        }
        let mut o = photo_options(&map, self.fill);
        o.angle_deg = finite("angle", self.angle)?;
        o.align = self.align;
        o.camera_radius_deg = super::check_camera_radius(self.camera_radius)?;
        o.reflectance = self
            .reflectance
            .as_ref()
            .map_or(Ok([1.0; 3]), Reflectance::rgb)?;
        Ok((o, map))
    }

    /// The camera of `photo`: orthographic, or perspective with the field of view of the
    /// request or of the photo's EXIF.
    fn model(&self, photo: &Photo) -> Result<(BallModel, Option<(f64, FovSource)>)> {
        if self.orthographic {
            return Ok((BallModel::Orthographic, None));
        }
        let (w, h) = (photo.image.width, photo.image.height);
        exif_hfov(
            self.fov,
            self.focal,
            self.sensor,
            photo.exif.as_deref(),
            w,
            h,
        )
        .map(|(hfov, from)| {
            (
                BallModel::Perspective { hfov_deg: hfov },
                Some((hfov, from)),
            )
        })
        .map_err(|e| match e {
            Error::InvalidParameter { name, reason } if photo.exif.is_some() => {
                Error::param(name, format!("{}: {reason}", photo.name))
            }
            Error::InvalidParameter { name, .. } if name == "fov" => Error::param(
                "fov",
                format!(
                    "the field of view of {} is unknown (texels have no EXIF): give fov, \
                     focal and sensor, or orthographic",
                    photo.name
                ),
            ),
            e => e,
        })
    }

    /// Unwarps `first` (and `second`, taken from about `angle` degrees around the ball).
    pub fn run(
        &self,
        first: &Photo,
        second: Option<&Photo>,
        progress: Option<&Progress>,
    ) -> Result<PhotoOutput> {
        let (opts, _) = self.resolve()?;
        let (m1, f1) = self.model(first)?;
        let s2 = second.map(|s| self.model(s)).transpose()?;
        let p1 = BallPhoto {
            image: &first.image,
            model: m1,
            circle: self.circle.map(|[cx, cy, r]| Circle { cx, cy, r }),
        };
        let p2 = second.zip(s2).map(|(s, (m, _))| BallPhoto {
            image: &s.image,
            model: m,
            circle: self.circle2.map(|[cx, cy, r]| Circle { cx, cy, r }),
        });
        let (map, mask, report) =
            from_mirror_ball(&p1, p2.as_ref(), &opts, progress).map_err(|e| {
                // The unwarp says "photo" and "second": name the photos as the caller does.
                let e = first.own(e, "photo");
                match second {
                    Some(s) => s.own(e, "second"),
                    None => e,
                }
            })?;
        let fovs: Vec<_> = std::iter::once(f1).chain(s2.map(|s| s.1)).collect();
        Ok(PhotoOutput {
            map,
            mask,
            report,
            models: fovs.iter().map(describe_ball).collect(),
            fovs,
        })
    }

    /// Reads `first` (and `second`), unwarps them and writes the map to `output` (and its
    /// confidence to `mask`) with `write`; refuses an output that is an input unless `force`,
    /// before any work.
    #[allow(clippy::too_many_arguments)]
    pub fn run_files(
        &self,
        first: &str,
        second: Option<&str>,
        output: &str,
        mask: Option<&str>,
        write: &WriteOptions,
        force: bool,
        progress: Option<&Progress>,
    ) -> Result<PhotoRunReport> {
        let (_, map) = self.resolve()?;
        let inputs: Vec<&str> = std::iter::once(first).chain(second).collect();
        let files = Files {
            inputs: &inputs,
            output,
            mask,
            write,
            force,
        };
        let how = (&self.map, &map, self.fill, self.linear, self.nonfinite);
        on_files(&files, how, |p| self.run(&p[0], p.get(1), progress))
    }
}

/// How a mirror-ball photo's camera was modelled, for the report.
fn describe_ball(f: &Option<(f64, FovSource)>) -> String {
    match f {
        None => "orthographic".into(),
        Some((hfov, from)) => format!(
            "perspective, horizontal field of view {hfov:.3}° ({})",
            from.describe()
        ),
    }
}

impl FisheyeRequest {
    /// Every field checked (errors name the field), as the unwarp's options and the lens'
    /// model and field of view.
    pub fn resolve(&self) -> Result<(PhotoOptions, ResolvedMap, LensModel, f64)> {
        let name = self
            .model
            .ok_or_else(|| Error::param("model", "required: the lens model"))?;
        let fov = finite(
            "fov",
            self.fov.ok_or_else(|| Error::param("fov", "required"))?,
        )?;
        if self.k.is_some() && name != LensName::Polynomial {
            return Err(Error::param(
                "k",
                "only the polynomial model takes coefficients",
            ));
        }
        let k = self.k.unwrap_or([0.0; 4]);
        if k.iter().any(|v| !v.is_finite()) {
            return Err(Error::param("k", format!("must be finite, got {k:?}")));
        }
        let model = LensModel::parse(name.name(), k)?;
        let map = resolve_map(&self.map)?;
        Ok((photo_options(&map, self.fill), map, model, fov))
    }

    /// Unwarps `photo`.
    pub fn run(&self, photo: &Photo, progress: Option<&Progress>) -> Result<PhotoOutput> {
        let (opts, _, model, fov) = self.resolve()?;
        let img = &photo.image;
        let centre = self
            .centre
            .unwrap_or([0.5 * img.width as f64, 0.5 * img.height as f64]);
        let radius = self
            .radius
            .unwrap_or(0.5 * img.width.min(img.height) as f64);
        let lens = Lens::new(model, fov, centre, radius)?;
        let (map, mask, report) =
            from_fisheye(img, lens, &opts, progress).map_err(|e| photo.own(e, "image"))?;
        let name = self.model.map_or("", |m| m.name());
        Ok(PhotoOutput {
            map,
            mask,
            report,
            models: vec![format!("fisheye, {name} {fov}°")],
            fovs: vec![None],
        })
    }

    /// Reads `input`, unwarps it and writes the map to `output` (and its confidence to
    /// `mask`), as [`BallRequest::run_files`].
    #[allow(clippy::too_many_arguments)]
    pub fn run_files(
        &self,
        input: &str,
        output: &str,
        mask: Option<&str>,
        write: &WriteOptions,
        force: bool,
        progress: Option<&Progress>,
    ) -> Result<PhotoRunReport> {
        let (_, map, _, _) = self.resolve()?;
        let files = Files {
            inputs: &[input],
            output,
            mask,
            write,
            force,
        };
        let how = (&self.map, &map, self.fill, self.linear, self.nonfinite);
        on_files(&files, how, |p| self.run(&p[0], progress))
    }
}

/// The files of a photo route: its photos, the map and its mask, how they are written and
/// whether an output may be an input.
struct Files<'a> {
    inputs: &'a [&'a str],
    output: &'a str,
    mask: Option<&'a str>,
    write: &'a WriteOptions,
    force: bool,
}

/// Reads the photos of `files`, runs `run` on them and writes its map; `how`: the output map
/// as asked and resolved, the fill, and how photos are read (`linear`, `nonfinite`).
fn on_files(
    files: &Files,
    how: (&MapRequest, &ResolvedMap, Fill, bool, NonFinite),
    run: impl FnOnce(Vec<Photo>) -> Result<PhotoOutput>,
) -> Result<PhotoRunReport> {
    let t0 = std::time::Instant::now();
    let (request, map, fill, linear, nonfinite) = how;
    check_outputs(files.inputs, files.output, files.mask, map, files.force)?;
    let photos = files
        .inputs
        .iter()
        .map(|p| Photo::read(p, linear, nonfinite))
        .collect::<Result<Vec<_>>>()?;
    let out = run(photos)?;
    let seconds = t0.elapsed().as_secs_f64();
    let wopts = WriteOptions {
        linear,
        ..*files.write
    };
    let mut written = write_env(
        files.output,
        map.mapping,
        &out.map,
        map.layout,
        &map.view,
        &wopts,
    )?;
    if let Some(m) = files.mask {
        // The mask is data: linear whatever the format.
        let mopts = WriteOptions {
            linear: true,
            ..*files.write
        };
        written.extend(write_env(
            m,
            map.mapping,
            &out.mask,
            map.layout,
            &map.view,
            &mopts,
        )?);
    }
    let losses = Format::from_extension(Path::new(&written[0]))
        .map(|f| Losses::of(&out.map, f, &wopts))
        .unwrap_or_default();
    Ok(PhotoRunReport {
        inputs: files.inputs.iter().map(|i| i.to_string()).collect(),
        output: written,
        models: out.models,
        to: map.mapping.name(),
        preset: map.mapping.preset_name(),
        size: request.size,
        samples: request.samples,
        fill,
        seconds,
        summary: out.report.summary(),
        losses: losses.into(),
    })
}

/// Refuses outputs that would overwrite an input (unless `force`), or that cannot hold the
/// map's mapping; before any work.
fn check_outputs(
    inputs: &[&str],
    output: &str,
    mask: Option<&str>,
    map: &ResolvedMap,
    force: bool,
) -> Result<()> {
    let outs: Vec<EnvFiles> = std::iter::once(output)
        .chain(mask)
        .map(EnvFiles::parse)
        .collect();
    if !force {
        let ins: Vec<String> = inputs.iter().map(|s| s.to_string()).collect();
        let paths: Vec<String> = outs.iter().flat_map(EnvFiles::paths).collect();
        refuse_overwrite(&ins, &paths)?;
    }
    for o in &outs {
        o.check_output(map.mapping)?;
    }
    Ok(())
}

impl PhotoOutput {
    /// The report as Python returns it.
    pub fn summary(&self) -> PhotoSummary {
        self.report.summary()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jobs::fields::read;

    fn ball(json: &str) -> Result<BallRequest> {
        read(&serde_json::from_str(json).unwrap(), &[])
    }

    fn fisheye(json: &str) -> Result<FisheyeRequest> {
        read(&serde_json::from_str(json).unwrap(), &[])
    }

    fn refused(r: Result<(PhotoOptions, ResolvedMap)>, field: &str) {
        let e = r.expect_err("refused").to_string();
        assert!(e.starts_with(&format!("{field}: ")), "{e}");
    }

    #[test]
    fn defaults_are_the_unwarps() {
        let (o, map) = BallRequest::default().resolve().unwrap();
        assert_eq!(
            (o.angle_deg, o.camera_radius_deg, o.align),
            (90.0, 20.0, true)
        );
        assert_eq!(o.reflectance, [1.0; 3]);
        assert_eq!(
            (map.width, map.height, map.mapping.name()),
            (512, 512, "sphere")
        );
        // The flattened output map reads its fields from the same table.
        let r = ball(r#"{"size": 64, "to": "latlong", "reflectance": 0.5, "fov": 30}"#).unwrap();
        let (o, map) = r.resolve().unwrap();
        assert_eq!((map.width, map.height), (128, 64));
        assert_eq!(o.reflectance, [0.5; 3]);
    }

    #[test]
    fn every_mistake_names_its_field() {
        let mut r = BallRequest {
            reflectance: Some(Reflectance::Rgb(vec![1.0, 2.0])),
            ..Default::default()
        };
        refused(r.resolve(), "reflectance");
        r.reflectance = Some(Reflectance::Grey(-1.0));
        refused(r.resolve(), "reflectance");
        r = BallRequest {
            circle2: Some([1.0, 2.0, -3.0]),
            ..Default::default()
        };
        refused(r.resolve(), "circle2");
        r = BallRequest {
            orthographic: true,
            fov: Some(30.0),
            ..Default::default()
        };
        refused(r.resolve(), "orthographic");
        r = BallRequest {
            angle: f64::NAN,
            ..Default::default()
        };
        refused(r.resolve(), "angle");
        r = BallRequest::default();
        r.map.pos = [1.0, 0.0, 0.0];
        refused(r.resolve(), "pos");
        r.map.pos = [0.0; 3];
        r.map.size = 0;
        refused(r.resolve(), "size");
        // Types and names, as read from a recipe's table or Python's keywords.
        for (json, field) in [
            (r#"{"fov": "wide"}"#, "fov"),
            (r#"{"fill": "magic"}"#, "fill"),
            (r#"{"samples": -1}"#, "samples"),
            (r#"{"filter": "lanczos"}"#, "filter"),
        ] {
            let e = ball(json).unwrap_err().to_string();
            assert!(e.starts_with(&format!("{field}: ")), "{json}: {e}");
        }
        let e = ball(r#"{"exposure": 1}"#).unwrap_err().to_string();
        assert!(e.starts_with("exposure: unknown field `exposure`"), "{e}");
    }

    #[test]
    fn a_fisheye_needs_its_model_and_fov() {
        let e = |r: &FisheyeRequest| r.resolve().expect_err("refused").to_string();
        assert!(e(&FisheyeRequest::default()).starts_with("model: required"));
        let r = fisheye(r#"{"model": "equisolid"}"#).unwrap();
        assert!(e(&r).starts_with("fov: required"));
        let r = fisheye(r#"{"model": "equisolid", "fov": 180, "k": [0, 0, 0, 0]}"#).unwrap();
        assert!(e(&r).starts_with("k: only the polynomial model"));
        let err = fisheye(r#"{"model": "fishy"}"#).unwrap_err().to_string();
        assert!(err.starts_with("model: unknown lens model"), "{err}");
        let r = fisheye(r#"{"model": "polynomial", "fov": 180, "k": [0.1, 0, 0, 0]}"#).unwrap();
        assert!(matches!(r.resolve().unwrap().2, LensModel::Polynomial(_)));
    }

    #[test]
    fn texels_have_no_exif_and_their_errors_name_the_argument() {
        let photo = Photo::texels(Image::new(8, 8, 3), "image", NonFinite::Error).unwrap();
        let e = BallRequest::default()
            .run(&photo, None, None)
            .err()
            .unwrap();
        assert!(
            e.to_string()
                .starts_with("fov: the field of view of image is unknown"),
            "{e}"
        );
        let mut bad = Image::new(4, 4, 3);
        bad.data[5] = f32::NAN;
        let e = Photo::texels(bad, "second", NonFinite::Error).unwrap_err();
        assert!(e.to_string().starts_with("second: "), "{e}");
    }
}
