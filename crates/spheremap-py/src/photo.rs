//! PyO3 glue for the photo routes (`spheremap::jobs::photo`'s requests) and the camera render
//! (`spheremap::trace::camera`).  No maths and no checks here: photos (paths or arrays) and a
//! request's fields in, the core's run, arrays and a report dictionary out.

use super::generate::Scene;
use super::{image_of, run_cancellable, to_py};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spheremap::images::codec::NonFinite;
use spheremap::images::Image;
use spheremap::jobs::photo::{self, BallRequest, FisheyeRequest, Photo, PhotoOutput};
use spheremap::resample::Progress;
use spheremap::trace::camera;

fn array<'py>(py: Python<'py>, img: Image) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, img.data)
        .reshape([img.height, img.width, img.channels])?
        .into_any())
}

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
    let a: PyReadonlyArrayDyn<'_, f32> = x.extract().map_err(|_| {
        PyValueError::new_err(format!(
            "{name}: expected a path or a float32 (H, W, C) array"
        ))
    })?;
    Photo::texels(image_of(&a, name)?, name, nonfinite).map_err(to_py)
}

type PhotoResult<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyDict>);

/// The map, its mask and the report as a dict (the CLI's `--json` keys, and for a mirror ball
/// `fov`: each photo's (field of view, where it came from), None when orthographic).
fn finish<'py>(py: Python<'py>, out: PhotoOutput, fov: bool) -> PyResult<PhotoResult<'py>> {
    let d = pythonize::pythonize(py, &out.summary())?.cast_into::<PyDict>()?;
    if fov {
        let fovs: Vec<Option<(f64, &str)>> = out
            .fovs
            .iter()
            .map(|f| f.map(|(v, from)| (v, from.describe())))
            .collect();
        d.set_item("fov", fovs)?;
    }
    Ok((array(py, out.map)?, array(py, out.mask)?, d))
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
    finish(py, out, true)
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
    finish(py, out, false)
}

/// The ball's outline in a photo: (cx, cy, r, rms, points, confidence, reflectance,
/// uncertainty); with a horizontal field of view, by the perspective rim model.
#[pyfunction]
#[pyo3(signature = (image, fov, linear))]
#[allow(clippy::type_complexity)]
pub fn find_ball(
    py: Python<'_>,
    image: &Bound<'_, PyAny>,
    fov: Option<f64>,
    linear: bool,
) -> PyResult<(f64, f64, f64, f64, usize, f64, Option<f64>, Option<f64>)> {
    let img = photo_arg(image, "image", linear, NonFinite::Error)?.image;
    let fit = py
        .detach(|| match fov {
            Some(f) => photo::find_ball_perspective(&img, f),
            None => photo::find_circle(&img, None),
        })
        .map_err(to_py)?;
    Ok((
        fit.circle.cx,
        fit.circle.cy,
        fit.circle.r,
        fit.rms,
        fit.points.len(),
        fit.confidence,
        fit.reflectance,
        fit.uncertainty,
    ))
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
    array(py, img)
}
