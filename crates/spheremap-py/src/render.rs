//! PyO3 glue for the rasterizer (`spheremap::jobs::render`) and the mesh loader. No maths here.

use super::args::{env_arg, image_out, rows_f32};
use super::to_py;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spheremap::jobs::render::RenderRequest;
use spheremap::mesh::Mesh;

type MeshArrays<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>);

/// OBJ/glTF -> (positions (N,3) f32, normals (N,3) f32, triangles (M,3) u32).
#[pyfunction]
pub fn load_mesh<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<MeshArrays<'py>> {
    let m = py
        .detach(|| spheremap::mesh::load_mesh(&path))
        .map_err(to_py)?;
    let (n, t) = (m.positions.len(), m.triangles.len());
    Ok((
        PyArray1::from_vec(py, m.positions.into_flattened())
            .reshape([n, 3])?
            .into_any(),
        PyArray1::from_vec(py, m.normals.into_flattened())
            .reshape([n, 3])?
            .into_any(),
        PyArray1::from_vec(py, m.triangles.into_flattened())
            .reshape([t, 3])?
            .into_any(),
    ))
}

/// (M, 3) triangle indices: non-negative integers of any integer dtype.
fn triangles_arg(ob: &Bound<'_, PyAny>) -> PyResult<Vec<[u32; 3]>> {
    let np = ob.py().import("numpy")?;
    let a = np.call_method1("asarray", (ob,))?;
    let u = a.cast::<PyUntypedArray>()?;
    let kind: String = u.dtype().getattr("kind")?.extract()?;
    let shape = u.shape().to_vec();
    let bad = || {
        PyValueError::new_err(format!(
            "triangles: expected (M, 3) non-negative integers, got {} {}",
            u.dtype(),
            super::args::shape_text(&shape)
        ))
    };
    if !matches!(kind.as_str(), "i" | "u") || shape.len() != 2 || shape[1] != 3 {
        return Err(bad());
    }
    let t: PyReadonlyArrayDyn<'_, i64> = np
        .call_method1(
            "ascontiguousarray",
            (a.call_method1("astype", ("int64",))?,),
        )?
        .extract()?;
    let v = t.as_slice()?;
    if v.iter().any(|&i| !(0..=u32::MAX as i64).contains(&i)) {
        return Err(bad());
    }
    Ok(v.chunks_exact(3)
        .map(|c| [c[0] as u32, c[1] as u32, c[2] as u32])
        .collect())
}

/// A mesh argument: a path (OBJ, glTF/GLB) or (positions (N, 3), normals (N, 3) or None,
/// triangles (M, 3)); without normals, angle-weighted ones; indices checked.
fn mesh_arg(py: Python<'_>, ob: &Bound<'_, PyAny>) -> PyResult<Mesh> {
    if let Ok(path) = ob.extract::<std::path::PathBuf>() {
        return py
            .detach(|| spheremap::mesh::load_mesh(&path))
            .map_err(to_py);
    }
    let (p, n, t): (Bound<'_, PyAny>, Option<Bound<'_, PyAny>>, Bound<'_, PyAny>) =
        ob.extract().map_err(|_| {
            PyValueError::new_err("mesh: expected a path or (positions, normals, triangles)")
        })?;
    let cast = |v: Vec<f32>| -> Vec<[f32; 3]> { bytemuck::cast_slice(&v).to_vec() };
    let positions = cast(rows_f32(&p, "positions", 3)?);
    let triangles = triangles_arg(&t)?;
    if let Some(t) = triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= positions.len()))
    {
        return Err(PyValueError::new_err(format!(
            "triangles: {t:?} indexes past the {} positions",
            positions.len()
        )));
    }
    let (normals, from_file) = match n {
        Some(n) => (cast(rows_f32(&n, "normals", 3)?), true),
        None => (
            spheremap::mesh::vertex_normals(&positions, &triangles),
            false,
        ),
    };
    if normals.len() != positions.len() {
        return Err(PyValueError::new_err(format!(
            "normals: {} normals for {} positions",
            normals.len(),
            positions.len()
        )));
    }
    Ok(Mesh {
        positions,
        normals,
        triangles,
        normals_from_file: from_file,
    })
}

/// Draws a mesh -> (H, W, 3) float32 (error mode: (H, W, 2) degrees and coverage).  `env`: a
/// path (read as `src`, `src_preset`, `src_layout` say, else as its note says, else as a sphere
/// map) or an array (default a sphere map); `request`: a `RenderRequest`'s fields.
#[pyfunction]
#[pyo3(signature = (mesh, env, src, src_preset, src_layout, linear, request))]
#[allow(clippy::too_many_arguments)]
pub fn render<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyAny>,
    env: Option<&Bound<'py, PyAny>>,
    src: Option<String>,
    src_preset: Option<String>,
    src_layout: Option<String>,
    linear: bool,
    request: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let request = render_request(request)?;
    let mesh = mesh_arg(py, mesh)?;
    let files = spheremap::jobs::render::RenderFiles {
        source: spheremap::jobs::source::Source {
            src,
            src_preset,
            src_layout,
            ..Default::default()
        },
        linear,
        ..Default::default()
    };
    let path = env.and_then(|e| e.extract::<std::path::PathBuf>().ok());
    let (env, what) = match (env, path) {
        (Some(_), Some(path)) => {
            let path = path.to_string_lossy().into_owned();
            let read = py.detach(|| files.read_env(&path)).map_err(to_py)?;
            (Some(read), path)
        }
        (e, _) => {
            let r = files
                .source
                .resolve(None, "env", Some("sphere"))
                .map_err(to_py)?;
            let cube = r.mapping.name() == "cube";
            let img = e
                .map(|e| env_arg(e, cube, r.layout.map(|l| l.name()), "env"))
                .transpose()?;
            (img.map(|i| (r.mapping, i)), "env".to_string())
        }
    };
    let (out, _, _) = py
        .detach(|| request.run_image(&mesh, env, &what))
        .map_err(to_py)?;
    image_out(py, out, false)
}

/// A dict of the core's `RenderRequest` fields.
fn render_request(request: &Bound<'_, PyAny>) -> PyResult<RenderRequest> {
    super::request_of(request)
}

/// Sampling analytics (`spheremap analyze`): `request` is an `AnalyzeRequest`'s fields; `map`
/// (a path or an array: (H, W[, C]), a cube's (6, F, F, C) faces) gives the canvas's size,
/// else the request's `size` does; `mesh` a path or (positions, normals or None, triangles).
/// -> a dict: "mapping", "width", "height", "solid_angle", "anisotropy", "resolution_deg"
/// ((H, W) float64, NaN off the map), "stats", "summary" (the core's `AnalyzeSummary`) and with
/// a mesh "mesh": "triangle_error_deg", "in_view", "split", "over", "uniform_split",
/// "triangles_after_adaptive", "unfixable", "max_split", "pixel_error_deg" ((H, W), NaN where
/// no surface).
#[pyfunction]
#[pyo3(signature = (map, mesh, request))]
pub fn analyze<'py>(
    py: Python<'py>,
    map: Option<&Bound<'py, PyAny>>,
    mesh: Option<&Bound<'py, PyAny>>,
    request: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let req: spheremap::jobs::analyze::AnalyzeRequest = super::request_of(request)?;
    let mapping = req.resolve().map_err(to_py)?;
    let size = match map {
        Some(map) => {
            let shape = match map.extract::<std::path::PathBuf>() {
                Ok(path) => {
                    let opts = spheremap::images::codec::ReadOptions::default();
                    let img = py
                        .detach(|| spheremap::images::codec::read_image(&path, &opts))
                        .map_err(to_py)?;
                    vec![img.height, img.width, img.channels]
                }
                Err(_) => super::args::FArr::extract(map, "map")?.shape(),
            };
            Some(match shape.as_slice() {
                [6, f, _, _] if mapping.name() == "cube" => (*f, 6 * f),
                [h, w] | [h, w, _] => (*w, *h),
                _ => {
                    return Err(PyValueError::new_err(format!(
                        "map: expected an image (H, W[, C]), got shape {}",
                        super::args::shape_text(&shape)
                    )))
                }
            })
        }
        None => None,
    };
    let mesh = mesh.map(|m| mesh_arg(py, m)).transpose()?;
    let a = py
        .detach(|| req.run(size.map(|s| (s, "map")), mesh.as_ref().map(|m| (m, None))))
        .map_err(to_py)?;
    let (w, h) = (a.maps.width, a.maps.height);
    let arr = |v: Vec<f64>, shape: [usize; 2]| -> PyResult<Bound<'py, PyAny>> {
        Ok(PyArray1::from_vec(py, v).reshape(shape)?.into_any())
    };
    let d = PyDict::new(py);
    let s = &a.summary;
    d.set_item("mapping", s.mapping)?;
    d.set_item("width", w)?;
    d.set_item("height", h)?;
    d.set_item("solid_angle", arr(a.maps.solid_angle, [h, w])?)?;
    d.set_item("anisotropy", arr(a.maps.anisotropy, [h, w])?)?;
    d.set_item("resolution_deg", arr(a.maps.resolution_deg, [h, w])?)?;
    let stats = PyDict::new(py);
    stats.set_item("solid_angle", pythonize::pythonize(py, &s.solid_angle_sr)?)?;
    stats.set_item("anisotropy", pythonize::pythonize(py, &s.anisotropy)?)?;
    stats.set_item(
        "resolution_deg",
        pythonize::pythonize(py, &s.resolution_deg)?,
    )?;
    d.set_item("stats", stats)?;
    d.set_item("summary", pythonize::pythonize(py, s)?)?;
    if let (Some((err, heat)), Some(ms)) = (a.mesh, &s.mesh) {
        let m = PyDict::new(py);
        let pixel: Vec<f64> = heat
            .data
            .chunks_exact(2)
            .map(|p| if p[1] > 0.0 { p[0] as f64 } else { f64::NAN })
            .collect();
        m.set_item(
            "triangle_error_deg",
            PyArray1::from_vec(py, err.triangle_error_deg.clone()),
        )?;
        m.set_item("in_view", PyArray1::from_vec(py, err.in_view.clone()))?;
        m.set_item("split", PyArray1::from_vec(py, err.split.clone()))?;
        m.set_item("over", PyArray1::from_vec(py, err.over()))?;
        m.set_item("uniform_split", ms.uniform_split)?;
        m.set_item("triangles_after_adaptive", ms.triangles_after_adaptive)?;
        m.set_item("unfixable", ms.unfixable)?;
        m.set_item("max_split", ms.max_split)?;
        m.set_item("pixel_error_deg", arr(pixel, [heat.height, heat.width])?)?;
        d.set_item("mesh", m)?;
    }
    Ok(d)
}
