//! PyO3 glue for the rasterizer (`spheremap::jobs::render`) and the mesh loader. No maths here.

use super::{contiguous, parse_mapping, to_py};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spheremap::jobs::render::{EnvInput, RenderRequest};
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

fn rows<T: numpy::Element + Copy, const K: usize>(
    a: &PyReadonlyArrayDyn<'_, T>,
    name: &str,
) -> PyResult<Vec<[T; K]>> {
    if a.ndim() != 2 || a.shape()[1] != K {
        return Err(PyValueError::new_err(format!(
            "{name}: expected shape (N, {K}), got {:?}",
            a.shape()
        )));
    }
    Ok(contiguous(a, name)?
        .chunks_exact(K)
        .map(|c| std::array::from_fn(|i| c[i]))
        .collect())
}

/// A core mesh from (N,3) positions, optional (N,3) normals (else angle-weighted ones) and
/// (M,3) triangles, indices checked.
fn mesh_of(
    positions: &PyReadonlyArrayDyn<'_, f32>,
    normals: Option<&PyReadonlyArrayDyn<'_, f32>>,
    triangles: &PyReadonlyArrayDyn<'_, u32>,
) -> PyResult<Mesh> {
    let positions = rows::<f32, 3>(positions, "positions")?;
    let triangles = rows::<u32, 3>(triangles, "triangles")?;
    if let Some(t) = triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= positions.len()))
    {
        return Err(PyValueError::new_err(format!(
            "triangles: {t:?} indexes past the {} positions",
            positions.len()
        )));
    }
    let (normals, from_file) = match normals {
        Some(n) => (rows::<f32, 3>(n, "normals")?, true),
        None => (
            spheremap::mesh::vertex_normals(&positions, &triangles),
            false,
        ),
    };
    let mesh = Mesh {
        positions,
        normals,
        triangles,
        normals_from_file: from_file,
    };
    if mesh.normals.len() != mesh.positions.len() {
        return Err(PyValueError::new_err(format!(
            "normals: {} normals for {} positions",
            mesh.normals.len(),
            mesh.positions.len()
        )));
    }
    Ok(mesh)
}

/// Draws a mesh -> (H, W, 3) float32 (error mode: (H, W, 2) degrees and coverage).
#[pyfunction]
#[pyo3(signature = (positions, normals, triangles, env, env_mapping, env_preset, request))]
#[allow(clippy::too_many_arguments)]
pub fn render<'py>(
    py: Python<'py>,
    positions: PyReadonlyArrayDyn<'py, f32>,
    normals: Option<PyReadonlyArrayDyn<'py, f32>>,
    triangles: PyReadonlyArrayDyn<'py, u32>,
    env: Option<PyReadonlyArrayDyn<'py, f32>>,
    env_mapping: &str,
    env_preset: Option<&str>,
    request: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let request = render_request(request)?;
    let mode = request.mode();
    let wrap = request.wrap;
    let mesh = mesh_of(&positions, normals.as_ref(), &triangles)?;
    let cam = request.camera(&mesh.positions).map_err(to_py)?;
    let img = env
        .as_ref()
        .map(|e| super::image_of(e, "env"))
        .transpose()?;
    let (mapping, img) = request
        .environment(parse_mapping(env_mapping, env_preset)?, img, "env")
        .map_err(to_py)?;
    let input = EnvInput::new(mapping, img.as_ref(), wrap, "env").map_err(to_py)?;
    input.check(mode).map_err(to_py)?;
    let env = input.env();
    let opts = request.options().map_err(to_py)?;
    let (out, _) = py
        .detach(|| spheremap::jobs::render::render(&mesh, &cam, env, &opts))
        .map_err(to_py)?;
    Ok(PyArray1::from_vec(py, out.data)
        .reshape([out.height, out.width, out.channels])?
        .into_any())
}

/// A dict of the core's `RenderRequest` fields.
fn render_request(request: &Bound<'_, PyAny>) -> PyResult<RenderRequest> {
    super::request_of(request)
}

/// A mapping's texel maps -> (solid angle, anisotropy, resolution in degrees), each (H, W) f64,
/// on a `width` x `height` canvas, or on the mapping's canvas of `size` N (the core's bounds),
/// and their summary (the core's `AnalyzeSummary`, as `spheremap analyze --json` prints it).
#[pyfunction]
#[pyo3(signature = (mapping, preset, width=None, height=None, size=None))]
pub fn analyze_mapping<'py>(
    py: Python<'py>,
    mapping: &str,
    preset: Option<&str>,
    width: Option<usize>,
    height: Option<usize>,
    size: Option<usize>,
) -> PyResult<(MeshArrays<'py>, Bound<'py, PyAny>)> {
    let m = parse_mapping(mapping, preset)?;
    let (width, height) = match (size, width, height) {
        (Some(n), _, _) => spheremap::jobs::analyze::canvas(m, "size", n).map_err(to_py)?,
        (None, Some(w), Some(h)) => (w, h),
        _ => return Err(PyValueError::new_err("size: expected a size or a canvas")),
    };
    let a = py
        .detach(|| spheremap::jobs::analyze::mapping_maps(m, width, height))
        .map_err(to_py)?;
    let summary = pythonize::pythonize(py, &a.summary(m))?;
    let arr = |v: Vec<f64>| -> PyResult<Bound<'py, PyAny>> {
        Ok(PyArray1::from_vec(py, v)
            .reshape([height, width])?
            .into_any())
    };
    Ok((
        (
            arr(a.solid_angle)?,
            arr(a.anisotropy)?,
            arr(a.resolution_deg)?,
        ),
        summary,
    ))
}

/// Per-triangle and per-pixel error of a mesh and camera (the core's `mesh_report`) -> a dict:
/// "triangle_error_deg" (M,), "in_view" (M,) bool, "split" (M,) u32, "heat" (H, W, 2)
/// (degrees, coverage) and "summary" (the core's `MeshSummary`).
#[pyfunction]
#[pyo3(signature = (positions, normals, triangles, request, threshold))]
pub fn analyze_mesh<'py>(
    py: Python<'py>,
    positions: PyReadonlyArrayDyn<'py, f32>,
    normals: Option<PyReadonlyArrayDyn<'py, f32>>,
    triangles: PyReadonlyArrayDyn<'py, u32>,
    request: &Bound<'py, PyAny>,
    threshold: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let mesh = mesh_of(&positions, normals.as_ref(), &triangles)?;
    let cam = render_request(request)?
        .camera(&mesh.positions)
        .map_err(to_py)?;
    let (e, heat) = py
        .detach(|| spheremap::jobs::analyze::mesh_report(&mesh, &cam, threshold))
        .map_err(to_py)?;
    let d = PyDict::new(py);
    d.set_item(
        "summary",
        pythonize::pythonize(py, &e.summary(None, &heat))?,
    )?;
    d.set_item(
        "heat",
        PyArray1::from_vec(py, heat.data).reshape([heat.height, heat.width, 2])?,
    )?;
    d.set_item(
        "triangle_error_deg",
        PyArray1::from_vec(py, e.triangle_error_deg),
    )?;
    d.set_item("in_view", PyArray1::from_vec(py, e.in_view))?;
    d.set_item("split", PyArray1::from_vec(py, e.split))?;
    Ok(d)
}
