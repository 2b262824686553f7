//! PyO3 glue for the photo routes (`spheremap::jobs::photo`'s requests) and the camera render
//! (`spheremap::trace::camera`).  No maths and no checks here: photos (paths or arrays) and a
//! request's fields in, the core's run, arrays and a report dictionary out.

use super::args::{image_arg, image_out};
use super::generate::Scene;
use super::{run_cancellable, to_py};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spheremap::images::codec::NonFinite;
use spheremap::jobs::photo::{self, BallRequest, FisheyeRequest, Photo, PhotoOutput};
use spheremap::resample::Progress;
use spheremap::trace::camera;

/// A photo argument: a path (read by the request's rules, its bytes kept for EXIF) or float32
/// texels (H, W, C).
fn photo_arg(
    x: &Bound<'_, PyAny>,
    name: &str,
    linear: bool,
    nonfinite: NonFinite,
) -> PyResult<Photo> {
    if let Ok(path) = x.extract::<std::path::PathBuf>() {
        return Photo::read(&path.to_string_lossy(), linear, nonfinite).map_err(to_py);
    }
    Photo::texels(image_arg(x, name)?, name, nonfinite).map_err(to_py)
}

type PhotoResult<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyDict>);

/// The map, its mask and the report as a dict (the CLI's `--json` keys, and for a mirror ball
/// `fov`: each photo's (field of view, where it came from), None when orthographic).
fn finish<'py>(
    py: Python<'py>,
    out: PhotoOutput,
    fov: bool,
    map: &spheremap::trace::generate::MapRequest,
) -> PyResult<PhotoResult<'py>> {
    let cube =
        spheremap::Mapping::parse(&map.to, map.preset.as_deref()).is_ok_and(|m| m.name() == "cube");
    let d = pythonize::pythonize(py, &out.summary())?.cast_into::<PyDict>()?;
    if fov {
        let fovs: Vec<Option<(f64, &str)>> = out
            .fovs
            .iter()
            .map(|f| f.map(|(v, from)| (v, from.describe())))
            .collect();
        d.set_item("fov", fovs)?;
    }
    Ok((
        image_out(py, out.map, cube)?,
        image_out(py, out.mask, cube)?,
        d,
    ))
}

/// Mirror-ball photo(s) -> (map, mask, report); `request`: a `BallRequest`'s fields.
#[pyfunction]
#[pyo3(signature = (image, second, request))]
pub fn from_mirror_ball<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    second: Option<&Bound<'py, PyAny>>,
    request: &Bound<'py, PyAny>,
) -> PyResult<PhotoResult<'py>> {
    let req: BallRequest = super::request_of(request)?;
    let p1 = photo_arg(image, "image", req.linear, req.nonfinite)?;
    let p2 = second
        .map(|s| photo_arg(s, "second", req.linear, req.nonfinite))
        .transpose()?;
    let progress = Progress::default();
    let (req, p1, p2) = (&req, &p1, p2.as_ref());
    let out = run_cancellable(py, &progress, "the unwarp", |p| req.run(p1, p2, Some(p)))?;
    finish(py, out, true, &req.map)
}

/// A fisheye photo -> (map, mask, report); `request`: a `FisheyeRequest`'s fields.
#[pyfunction]
#[pyo3(signature = (image, request))]
pub fn from_fisheye<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    request: &Bound<'py, PyAny>,
) -> PyResult<PhotoResult<'py>> {
    let req: FisheyeRequest = super::request_of(request)?;
    let photo = photo_arg(image, "image", req.linear, req.nonfinite)?;
    let progress = Progress::default();
    let (req, photo) = (&req, &photo);
    let out = run_cancellable(py, &progress, "the unwarp", |p| req.run(photo, Some(p)))?;
    finish(py, out, false, &req.map)
}

/// The ball's outline in a photo, as a dict: "circle" (cx, cy, r), "fit_rms" (also
/// "fit_rms_px" for the edge fit, None for the rim model), "fit_points", "confidence",
/// "reflectance", "uncertainty_px"; with a horizontal field of view, by the perspective rim
/// model.
#[pyfunction]
#[pyo3(signature = (image, fov, linear))]
pub fn find_ball<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    fov: Option<f64>,
    linear: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let img = photo_arg(image, "image", linear, NonFinite::Error)?.image;
    let fit = py
        .detach(|| match fov {
            Some(f) => photo::find_ball_perspective(&img, f),
            None => photo::find_circle(&img, None),
        })
        .map_err(to_py)?;
    let d = PyDict::new(py);
    let c = &fit.circle;
    d.set_item("circle", (c.cx, c.cy, c.r))?;
    d.set_item("fit_rms", fit.rms)?;
    d.set_item("fit_rms_px", fov.is_none().then_some(fit.rms))?;
    d.set_item("fit_points", fit.points.len())?;
    d.set_item("confidence", fit.confidence)?;
    d.set_item("reflectance", fit.reflectance)?;
    d.set_item("uncertainty_px", fit.uncertainty)?;
    Ok(d)
}

/// What a camera sees of a scene: (H, W, 3) float32.
#[pyfunction]
#[pyo3(signature = (scene, request))]
pub fn render_camera<'py>(
    py: Python<'py>,
    scene: PyRef<'py, Scene>,
    request: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let req: camera::PreviewRequest = super::request_of(request)?;
    let cam = req.camera().map_err(to_py)?;
    let progress = Progress::default();
    let (cam, source) = (&cam, scene.inner());
    let img = run_cancellable(py, &progress, "the render", |p| {
        camera::render(cam, source, req.samples, req.seed, false, Some(p))
    })?;
    image_out(py, img, false)
}
