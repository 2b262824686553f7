//! PyO3 glue for the rasterizer (`spheremap::jobs::render`) and the mesh loader. No maths here.

use super::args::{env_arg, image_out, rows_f32};
use super::{parse_mapping, to_py};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArray, PyUntypedArrayMethods};
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
    use spheremap::images::codec::{check_nonfinite, NonFinite, ReadOptions};
    use spheremap::images::envmap::{read_env, read_note};
    let request = render_request(request)?;
    let mode = request.mode();
    let wrap = request.wrap;
    let mesh = mesh_arg(py, mesh)?;
    let cam = request.camera(&mesh.positions).map_err(to_py)?;
    let source = spheremap::jobs::source::Source {
        src,
        src_preset,
        src_layout,
        ..Default::default()
    };
    let path = env.and_then(|e| e.extract::<std::path::PathBuf>().ok());
    let (mapping, img) = match (env, path) {
        (Some(_), Some(path)) => {
            let path = path.to_string_lossy().into_owned();
            let note = read_note(&path).map_err(to_py)?;
            let r = source
                .resolve(note.as_ref(), &path, Some("sphere"))
                .map_err(to_py)?;
            let opts = ReadOptions {
                linear,
                ..Default::default()
            };
            let img = py.detach(|| {
                let mut img = read_env(&path, r.mapping, r.layout, &opts)?;
                check_nonfinite(&mut img, NonFinite::Error, &path)?;
                Ok::<_, spheremap::Error>(img)
            });
            (r.mapping, Some(img.map_err(to_py)?))
        }
        (e, _) => {
            let r = source.resolve(None, "env", Some("sphere")).map_err(to_py)?;
            let cube = r.mapping.name() == "cube";
            let img = e
                .map(|e| env_arg(e, cube, r.layout.map(|l| l.name()), "env"))
                .transpose()?;
            (r.mapping, img)
        }
    };
    let (mapping, img) = request.environment(mapping, img, "env").map_err(to_py)?;
    let input = EnvInput::new(mapping, img.as_ref(), wrap, "env").map_err(to_py)?;
    input.check(mode).map_err(to_py)?;
    let env = input.env();
    let opts = request.options().map_err(to_py)?;
    let (out, _) = py
        .detach(|| spheremap::jobs::render::render(&mesh, &cam, env, &opts))
        .map_err(to_py)?;
    image_out(py, out, false)
}

/// A dict of the core's `RenderRequest` fields.
fn render_request(request: &Bound<'_, PyAny>) -> PyResult<RenderRequest> {
    super::request_of(request)
}

/// A mapping's texel maps -> (solid angle, anisotropy, resolution in degrees), each (H, W) f64,
/// on the canvas of `map` (a path or an array: (H, W[, C]), a cube's (6, F, F, C) faces), or
/// on the mapping's canvas of `size` N (the core's bounds), and their summary (the core's
/// `AnalyzeSummary`, as `spheremap analyze --json` prints it).
#[pyfunction]
#[pyo3(signature = (mapping, preset, map=None, size=None))]
pub fn analyze_mapping<'py>(
    py: Python<'py>,
    mapping: &str,
    preset: Option<&str>,
    map: Option<&Bound<'py, PyAny>>,
    size: Option<&Bound<'py, PyAny>>,
) -> PyResult<(MeshArrays<'py>, Bound<'py, PyAny>)> {
    let m = parse_mapping(mapping, preset)?;
    let (width, height) = match (map, size) {
        (Some(map), _) => {
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
            match shape.as_slice() {
                [6, f, _, _] if m.name() == "cube" => (*f, 6 * f),
                [h, w] | [h, w, _] => (*w, *h),
                _ => {
                    return Err(PyValueError::new_err(format!(
                        "map: expected an image (H, W[, C]), got shape {}",
                        super::args::shape_text(&shape)
                    )))
                }
            }
        }
        (None, Some(n)) => {
            let n = super::args::positive(n, "size")?;
            spheremap::jobs::analyze::canvas(m, "size", n).map_err(to_py)?
        }
        (None, None) => return Err(PyValueError::new_err("size: expected a size or a map")),
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
#[pyo3(signature = (mesh, request, threshold))]
pub fn analyze_mesh<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyAny>,
    request: &Bound<'py, PyAny>,
    threshold: f64,
) -> PyResult<Bound<'py, PyDict>> {
    if !threshold.is_finite() {
        return Err(PyValueError::new_err(format!(
            "threshold: expected a finite number, got {threshold}"
        )));
    }
    let mesh = mesh_arg(py, mesh)?;
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
