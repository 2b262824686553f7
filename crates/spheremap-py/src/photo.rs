//! PyO3 glue for the photo routes (`spheremap::jobs::photo`) and the camera render
//! (`spheremap::trace::camera`).  No maths here: arrays and strings in, core calls, arrays and a report
//! dictionary out.  Argument checking with argument names is in `python/spheremap/__init__.py`.

use super::generate::Scene;
use super::{image_of, run_cancellable, to_py};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spheremap::images::Image;
use spheremap::jobs::photo::{self, BallModel, BallPhoto, Circle, Fill, PhotoOptions, PhotoReport};
use spheremap::mappings::fisheye::{Lens, LensModel};
use spheremap::resample::Progress;
use spheremap::trace::camera::{self, Camera, Projection};

fn array<'py>(py: Python<'py>, img: Image) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, img.data)
        .reshape([img.height, img.width, img.channels])?
        .into_any())
}

fn circle_of(c: Option<[f64; 3]>) -> Option<Circle> {
    c.map(|[cx, cy, r]| Circle { cx, cy, r })
}

/// The output side shared by both routes (the CLI's output flags): the core's `MapRequest` as
/// a dict, and the fill.
fn photo_options(request: &Bound<'_, PyAny>, fill: &str) -> PyResult<PhotoOptions> {
    let map = super::generate::map_request(request)?;
    Ok(PhotoOptions {
        mapping: map.mapping,
        width: map.width,
        height: map.height,
        generate: map.options,
        fill: Fill::parse(fill).map_err(to_py)?,
        ..Default::default()
    })
}

/// The report as a dict (the CLI's `--json` keys).
fn report_dict<'py>(py: Python<'py>, r: &PhotoReport) -> PyResult<Bound<'py, PyDict>> {
    Ok(pythonize::pythonize(py, &r.summary())?.cast_into::<PyDict>()?)
}

type PhotoResult<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyDict>);

fn finish<'py>(py: Python<'py>, out: (Image, Image, PhotoReport)) -> PyResult<PhotoResult<'py>> {
    let (map, mask, report) = out;
    let d = report_dict(py, &report)?;
    Ok((array(py, map)?, array(py, mask)?, d))
}

/// One photo's camera model: orthographic, or perspective with a field of view from the
/// arguments or the file's EXIF (`exif`: the file's bytes); returns the model and a description.
fn ball_model(
    orthographic: bool,
    fov: Option<f64>,
    focal: Option<f64>,
    sensor: Option<f64>,
    exif: Option<&[u8]>,
    img: &Image,
    name: &str,
) -> PyResult<(BallModel, Option<(f64, &'static str)>)> {
    if orthographic {
        return Ok((BallModel::Orthographic, None));
    }
    let (hfov, from) = photo::exif_hfov(fov, focal, sensor, exif, img.width, img.height)
        .map_err(|e| PyValueError::new_err(format!("{name}: {e}")))?;
    Ok((
        BallModel::Perspective { hfov_deg: hfov },
        Some((hfov, from.describe())),
    ))
}

/// Mirror-ball photo(s) -> (map, mask, report).
#[pyfunction]
#[pyo3(signature = (image, exif, second, exif2, orthographic, fov, focal, sensor, circle, circle2,
                    angle, align, reflectance, camera_radius, request, fill))]
#[allow(clippy::too_many_arguments)]
pub fn from_mirror_ball<'py>(
    py: Python<'py>,
    image: PyReadonlyArrayDyn<'py, f32>,
    exif: Option<Vec<u8>>,
    second: Option<PyReadonlyArrayDyn<'py, f32>>,
    exif2: Option<Vec<u8>>,
    orthographic: bool,
    fov: Option<f64>,
    focal: Option<f64>,
    sensor: Option<f64>,
    circle: Option<[f64; 3]>,
    circle2: Option<[f64; 3]>,
    angle: f64,
    align: bool,
    reflectance: [f32; 3],
    camera_radius: f64,
    request: &Bound<'py, PyAny>,
    fill: &str,
) -> PyResult<PhotoResult<'py>> {
    let mut opts = photo_options(request, fill)?;
    opts.reflectance = reflectance;
    opts.camera_radius_deg = camera_radius;
    opts.angle_deg = angle;
    opts.align = align;
    let img1 = image_of(&image, "image")?;
    let img2 = second.as_ref().map(|s| image_of(s, "second")).transpose()?;
    let (m1, fov1) = ball_model(
        orthographic,
        fov,
        focal,
        sensor,
        exif.as_deref(),
        &img1,
        "image",
    )?;
    let m2 = match &img2 {
        Some(i) => Some(ball_model(
            orthographic,
            fov,
            focal,
            sensor,
            exif2.as_deref(),
            i,
            "second",
        )?),
        None => None,
    };
    let p1 = BallPhoto {
        image: &img1,
        model: m1,
        circle: circle_of(circle),
    };
    let p2 = img2.as_ref().zip(m2).map(|(i, (m, _))| BallPhoto {
        image: i,
        model: m,
        circle: circle_of(circle2),
    });
    let progress = Progress::default();
    let (opts, p1r, p2r) = (&opts, &p1, p2.as_ref());
    let result = run_cancellable(py, &progress, "the unwarp", |p| {
        photo::from_mirror_ball(p1r, p2r, opts, Some(p))
    })?;
    let r = finish(py, result)?;
    let fovs: Vec<Option<(f64, &str)>> = std::iter::once(fov1).chain(m2.map(|m| m.1)).collect();
    r.2.set_item("fov", fovs)?;
    Ok(r)
}

/// A fisheye photo -> (map, mask, report).
#[pyfunction]
#[pyo3(signature = (image, model, k, fov, centre, radius, request, fill))]
#[allow(clippy::too_many_arguments)]
pub fn from_fisheye<'py>(
    py: Python<'py>,
    image: PyReadonlyArrayDyn<'py, f32>,
    model: &str,
    k: [f64; 4],
    fov: f64,
    centre: Option<[f64; 2]>,
    radius: Option<f64>,
    request: &Bound<'py, PyAny>,
    fill: &str,
) -> PyResult<PhotoResult<'py>> {
    let opts = photo_options(request, fill)?;
    let img = image_of(&image, "image")?;
    let model = LensModel::parse(model, k).map_err(to_py)?;
    let centre = centre.unwrap_or([0.5 * img.width as f64, 0.5 * img.height as f64]);
    let radius = radius.unwrap_or(0.5 * img.width.min(img.height) as f64);
    let lens = Lens::new(model, fov, centre, radius).map_err(to_py)?;
    let progress = Progress::default();
    let (img, opts) = (&img, &opts);
    let result = run_cancellable(py, &progress, "the unwarp", |p| {
        photo::from_fisheye(img, lens, opts, Some(p))
    })?;
    finish(py, result)
}

/// The ball's outline in a photo: (cx, cy, r, rms, points, confidence, reflectance,
/// uncertainty); with a horizontal field of view, by the perspective rim model.
#[pyfunction]
#[pyo3(signature = (image, fov))]
#[allow(clippy::type_complexity)]
pub fn find_ball(
    py: Python<'_>,
    image: PyReadonlyArrayDyn<'_, f32>,
    fov: Option<f64>,
) -> PyResult<(f64, f64, f64, f64, usize, f64, Option<f64>, Option<f64>)> {
    let img = image_of(&image, "image")?;
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
#[pyo3(signature = (scene, eye, target, up, fov, lens, width, height, samples, seed))]
#[allow(clippy::too_many_arguments)]
pub fn render_camera<'py>(
    py: Python<'py>,
    scene: PyRef<'py, Scene>,
    eye: [f64; 3],
    target: [f64; 3],
    up: [f64; 3],
    fov: f64,
    lens: Option<&str>,
    width: usize,
    height: usize,
    samples: u32,
    seed: u64,
) -> PyResult<Bound<'py, PyAny>> {
    let projection = match lens {
        None => Projection::Perspective { hfov_deg: fov },
        Some(m) => Projection::Fisheye(
            Lens::new(
                LensModel::parse(m, [0.0; 4]).map_err(to_py)?,
                fov,
                [0.5 * width as f64, 0.5 * height as f64],
                0.5 * width.min(height) as f64,
            )
            .map_err(to_py)?,
        ),
    };
    let cam = Camera::look_at(projection, eye, target, up, width, height).map_err(to_py)?;
    let progress = Progress::default();
    let (cam, source) = (&cam, scene.inner());
    let img = run_cancellable(py, &progress, "the render", |p| {
        camera::render(cam, source, samples, seed, false, Some(p))
    })?;
    array(py, img)
}
