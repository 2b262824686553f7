//! PyO3 glue for `spheremap`: translate numpy arrays and strings to core calls, release the GIL
//! while the core works, map core errors to Python exceptions.  No maths here.
//!
//! The public Python API (signatures, docstrings) is `python/spheremap`; it forwards its
//! arguments as given, and [`args`] reads them (arrays of any memory order, Python sequences,
//! positive integers), each error naming the argument.

use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyValueError};
use pyo3::prelude::*;
use rayon::prelude::*;
use spheremap::mappings::texgen::{Elem, ModelviewState, NormalMode, TexgenOptions};
use spheremap::{MatcapVariant, Singular, SpherePreset};

use args::{image_arg, image_out, positive, FArr};

mod args;
mod batch;
mod generate;
mod photo;
mod render;
mod view;

pyo3::create_exception!(
    _spheremap,
    Error,
    PyValueError,
    "Base class of spheremap's own errors."
);
pyo3::create_exception!(
    _spheremap,
    DataError,
    Error,
    "A file or buffer holds data spheremap cannot use."
);
pyo3::create_exception!(
    _spheremap,
    LimitError,
    Error,
    "The input or the job is over a configured limit (dimensions, memory)."
);
pyo3::create_exception!(
    _spheremap,
    UnsupportedError,
    Error,
    "Valid input that spheremap does not handle."
);

/// Warnings the core gave while the GIL was released ([`spheremap::base::error::warn`]), waiting to
/// be emitted as `UserWarning`s by [`emit_warnings`].
static WARNINGS: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());

fn queue_warning(msg: &str) {
    WARNINGS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(msg.to_string());
}

/// Emits the queued core warnings as `UserWarning`s (called after each core call that reads
/// files).
pub(crate) fn emit_warnings(py: Python<'_>) -> PyResult<()> {
    let pending = std::mem::take(&mut *WARNINGS.lock().unwrap_or_else(|e| e.into_inner()));
    for w in pending {
        let msg = std::ffi::CString::new(w.replace('\0', " ")).expect("no NUL left");
        PyErr::warn(
            py,
            py.get_type::<pyo3::exceptions::PyUserWarning>().as_any(),
            &msg,
            2,
        )?;
    }
    Ok(())
}

/// The one mapping from core errors to Python exceptions.
pub(crate) fn to_py(e: spheremap::Error) -> PyErr {
    use spheremap::Error as E;
    let msg = e.to_string();
    match e {
        E::InvalidParameter { .. } => PyValueError::new_err(msg),
        E::InvalidData { .. } => DataError::new_err(msg),
        E::Unsupported { .. } => UnsupportedError::new_err(msg),
        E::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(msg)
        }
        E::Io { .. } => PyOSError::new_err(msg),
        E::Cancelled { .. } => pyo3::exceptions::PyKeyboardInterrupt::new_err(msg),
        E::Limit { .. } => LimitError::new_err(msg),
    }
}

fn contiguous<'a, T: numpy::Element>(
    a: &'a PyReadonlyArrayDyn<'_, T>,
    name: &str,
) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name}: array must be C-contiguous")))
}

/// `out` rows of `O` values from `input` rows of `I` values, in parallel for large inputs.
fn map_rows<T: Copy + Send + Sync, U: Copy + Send + Sync, const I: usize, const O: usize>(
    input: &[T],
    out: &mut [U],
    f: impl Fn([T; I]) -> [U; O] + Sync,
) {
    let run = |inp: &[T], o: &mut [U]| {
        for (a, b) in inp.chunks_exact(I).zip(o.chunks_exact_mut(O)) {
            b.copy_from_slice(&f(std::array::from_fn(|k| a[k])));
        }
    };
    const ROWS: usize = 8192;
    if input.len() / I < 2 * ROWS {
        run(input, out);
    } else {
        input
            .par_chunks(I * ROWS)
            .zip(out.par_chunks_mut(O * ROWS))
            .for_each(|(a, b)| run(a, b));
    }
}

fn out_shape(shape: &[usize], last: usize) -> Vec<usize> {
    let mut s = shape[..shape.len() - 1].to_vec();
    s.push(last);
    s
}

/// Maps each row of `I` values of the array argument `ob` (read as float64; its last dimension
/// must be `I`) to `O` values, into a new float64 array of the same leading shape, in parallel
/// and without the GIL.
fn map_f64_rows<'py, const I: usize, const O: usize>(
    py: Python<'py>,
    ob: &Bound<'py, PyAny>,
    name: &str,
    f: impl Fn([f64; I]) -> [f64; O] + Sync + Send,
) -> PyResult<Bound<'py, PyAny>> {
    let arr = FArr::extract(ob, name)?;
    arr.check(name, None, &[I])?;
    let shape = arr.shape();
    let inp = arr.to_f64();
    let out = PyArrayDyn::<f64>::zeros(py, out_shape(&shape, O), false);
    let mut w = out.readwrite();
    let o = w.as_slice_mut().expect("fresh array is contiguous");
    py.detach(|| map_rows::<f64, f64, I, O>(&inp, o, f));
    drop(w);
    Ok(out.into_any())
}

#[pyfunction]
#[pyo3(signature = (positions, normals, modelview, normalize, singular, precision, out=None))]
#[allow(clippy::too_many_arguments)]
fn sphere_texgen<'py>(
    py: Python<'py>,
    positions: &Bound<'py, PyAny>,
    normals: &Bound<'py, PyAny>,
    modelview: &Bound<'py, PyAny>,
    normalize: &str,
    singular: &str,
    precision: &str,
    out: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let opts = TexgenOptions {
        normalize: NormalMode::parse_as(normalize, "normalize").map_err(to_py)?,
        singular: Singular::parse_as(singular, "singular").map_err(to_py)?,
    };
    let m = FArr::extract(modelview, "modelview")?;
    if m.shape() != [4, 4] {
        return Err(PyValueError::new_err(format!(
            "modelview: expected shape (4, 4), got {}",
            args::shape_text(&m.shape())
        )));
    }
    let m = m.to_f64();
    let mv = ModelviewState::new(std::array::from_fn(|r| {
        std::array::from_fn(|c| m[4 * r + c])
    }))
    .map_err(to_py)?;
    let pos = FArr::extract(positions, "positions")?;
    pos.check("positions", Some(2), &[3, 4])?;
    let nrm = FArr::extract(normals, "normals")?;
    nrm.check("normals", Some(2), &[3])?;
    let (ps, ns) = (pos.shape(), nrm.shape());
    let n = ps[0];
    let pw = ps[1];
    if ns[0] != n {
        return Err(PyValueError::new_err(format!(
            "normals: expected {n} rows to match positions, got shape {}",
            args::shape_text(&ns)
        )));
    }
    #[allow(clippy::too_many_arguments)]
    fn go<'py, P: Elem + numpy::Element, N: Elem + numpy::Element>(
        py: Python<'py>,
        p: &PyReadonlyArrayDyn<'_, P>,
        q: &PyReadonlyArrayDyn<'_, N>,
        pw: usize,
        mv: &ModelviewState,
        opts: TexgenOptions,
        f64_out: bool,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
        let (p, q) = (contiguous(p, "positions")?, contiguous(q, "normals")?);
        let n = p.len() / pw;
        let shape_err = || {
            PyValueError::new_err(format!(
                "out: expected a writable C-contiguous ({n}, 2) array"
            ))
        };
        if f64_out {
            let out = match out {
                Some(o) => o.cast_into::<PyArrayDyn<f64>>().map_err(|_| {
                    PyValueError::new_err("out: expected a float64 array with precision='f64'")
                })?,
                None => PyArrayDyn::<f64>::zeros(py, vec![n, 2], false),
            };
            if out.shape() != [n, 2] || !out.is_c_contiguous() {
                return Err(shape_err());
            }
            let mut w = out.try_readwrite().map_err(|_| shape_err())?;
            let o = w.as_slice_mut().map_err(|_| shape_err())?;
            py.detach(|| spheremap::sphere_texgen_f64(p, pw, q, mv, opts, o))
                .map_err(to_py)?;
            drop(w);
            Ok(out.into_any().unbind())
        } else {
            let out = match out {
                Some(o) => o
                    .cast_into::<PyArrayDyn<f32>>()
                    .map_err(|_| PyValueError::new_err("out: expected a float32 array"))?,
                // SAFETY: every element is written by sphere_texgen before the array is returned.
                None => unsafe { PyArrayDyn::<f32>::new(py, vec![n, 2], false) },
            };
            if out.shape() != [n, 2] || !out.is_c_contiguous() {
                return Err(shape_err());
            }
            let mut w = out.try_readwrite().map_err(|_| shape_err())?;
            let o = w.as_slice_mut().map_err(|_| shape_err())?;
            py.detach(|| spheremap::sphere_texgen(p, pw, q, mv, opts, o))
                .map_err(to_py)?;
            drop(w);
            Ok(out.into_any().unbind())
        }
    }
    use spheremap::resample::Precision;
    let f64_out = Precision::parse_as(precision, "precision").map_err(to_py)? == Precision::F64;
    let r = match (&pos, &nrm) {
        (FArr::F32(p), FArr::F32(q)) => go(py, p, q, pw, &mv, opts, f64_out, out.clone()),
        (FArr::F32(p), FArr::F64(q)) => go(py, p, q, pw, &mv, opts, f64_out, out.clone()),
        (FArr::F64(p), FArr::F32(q)) => go(py, p, q, pw, &mv, opts, f64_out, out.clone()),
        (FArr::F64(p), FArr::F64(q)) => go(py, p, q, pw, &mv, opts, f64_out, out.clone()),
    }?;
    Ok(r.into_bound(py))
}

/// Applies a row function to a float array, keeping its dtype (f32 → f32 path, f64 → f64).
macro_rules! rowwise {
    ($py:expr, $arr:expr, $name:expr, $i:literal -> $o:literal, |$row:ident: $t:ident| $body:expr) => {{
        let arr = FArr::extract($arr, $name)?;
        let shape = arr.shape();
        if shape.last() != Some(&$i) {
            return Err(PyValueError::new_err(format!(
                "{}: last dimension must be {}, got shape {:?}",
                $name, $i, shape
            )));
        }
        match &arr {
            FArr::F32(a) => {
                type $t = f32;
                let inp = contiguous(a, $name)?;
                let out = PyArrayDyn::<f32>::zeros($py, out_shape(&shape, $o), false);
                let mut w = out.readwrite();
                let o = w.as_slice_mut().expect("fresh array is contiguous");
                $py.detach(|| map_rows::<f32, f32, $i, $o>(inp, o, |$row| $body));
                drop(w);
                out.into_any()
            }
            FArr::F64(a) => {
                type $t = f64;
                let inp = contiguous(a, $name)?;
                let out = PyArrayDyn::<f64>::zeros($py, out_shape(&shape, $o), false);
                let mut w = out.readwrite();
                let o = w.as_slice_mut().expect("fresh array is contiguous");
                $py.detach(|| map_rows::<f64, f64, $i, $o>(inp, o, |$row| $body));
                drop(w);
                out.into_any()
            }
        }
    }};
}

#[pyfunction]
fn dir_to_sphere<'py>(
    py: Python<'py>,
    dirs: &Bound<'py, PyAny>,
    singular: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let sg = Singular::parse_as(singular, "singular").map_err(to_py)?;
    Ok(rowwise!(py, dirs, "dirs", 3 -> 2, |r: T| spheremap::dir_to_st::<T>(r, sg)))
}

#[pyfunction]
fn sphere_to_dir<'py>(py: Python<'py>, st: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    Ok(rowwise!(py, st, "st", 2 -> 3, |r: T| spheremap::st_to_dir::<T>(r).unwrap_or([T::NAN; 3])))
}

/// Two (..., 3) array arguments broadcast together and stacked to (..., 6), in one dtype
/// (float64 when theirs differ).
fn stack3<'py>(
    a: &Bound<'py, PyAny>,
    a_name: &str,
    b: &Bound<'py, PyAny>,
    b_name: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let py = a.py();
    let np = py.import("numpy")?;
    let (x, y) = (FArr::extract(a, a_name)?, FArr::extract(b, b_name)?);
    x.check(a_name, None, &[3])?;
    y.check(b_name, None, &[3])?;
    let dtype = match (&x, &y) {
        (FArr::F32(_), FArr::F32(_)) => "float32",
        _ => "float64",
    };
    let (xs, ys) = (x.shape(), y.shape());
    let pair = np.call_method1("broadcast_arrays", (a, b)).map_err(|_| {
        PyValueError::new_err(format!(
            "{b_name}: shape {} does not broadcast with {a_name} {}",
            args::shape_text(&ys),
            args::shape_text(&xs)
        ))
    })?;
    let kw = pyo3::types::PyDict::new(py);
    kw.set_item("axis", -1)?;
    let stacked = np.call_method("concatenate", (pair,), Some(&kw))?;
    stacked.call_method1("astype", (dtype,))
}

#[pyfunction]
fn reflect<'py>(
    py: Python<'py>,
    incident: &Bound<'py, PyAny>,
    normal: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let un = stack3(incident, "incident", normal, "normal")?;
    Ok(
        rowwise!(py, &un, "incident/normal", 6 -> 3, |r: T| spheremap::reflect::<T>([r[0], r[1], r[2]], [r[3], r[4], r[5]])),
    )
}

#[pyfunction]
#[pyo3(signature = (normals, positions, variant, scale))]
fn matcap_uv<'py>(
    py: Python<'py>,
    normals: &Bound<'py, PyAny>,
    positions: Option<&Bound<'py, PyAny>>,
    variant: &str,
    scale: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let v = MatcapVariant::parse_as(variant, "variant").map_err(to_py)?;
    let sc = scale.unwrap_or(v.default_scale());
    if !sc.is_finite() {
        return Err(PyValueError::new_err("scale: must be finite"));
    }
    let has_positions = positions.is_some();
    // (..., 6): normal then position (ignored unless has_positions).
    let stacked = match positions {
        Some(p) => stack3(normals, "normals", p, "positions")?,
        None => stack3(normals, "normals", normals, "normals")?,
    };
    Ok(rowwise!(py, &stacked, "normals", 6 -> 2, |r: T| {
        let p = if has_positions { Some([r[3], r[4], r[5]]) } else { None };
        spheremap::matcap_uv::<T>([r[0], r[1], r[2]], p, v, <T as spheremap::base::real::Real>::from_f64(sc))
    }))
}

/// `n` as an image side for the argument `what`, by the core's limit.
fn image_side(what: &str, n: usize) -> PyResult<usize> {
    spheremap::base::limits::check_range(what, n, 1, spheremap::base::limits::IMAGE_SIDE)
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

#[pyfunction]
fn sphere_texel_solid_angle<'py>(
    py: Python<'py>,
    size: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let size = image_side("size", positive(size, "size")?)?;
    let v = py.detach(|| spheremap::mappings::sphere::solid_angle_map(size));
    Ok(PyArray1::from_vec(py, v).reshape([size, size])?.into_any())
}

#[pyfunction]
fn dir_to_pixel<'py>(
    py: Python<'py>,
    dirs: &Bound<'py, PyAny>,
    size: &Bound<'py, PyAny>,
    preset: &str,
    singular: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let size = image_side("size", positive(size, "size")?)?;
    let p = SpherePreset::by_name(preset).map_err(to_py)?;
    let sg = Singular::parse_as(singular, "singular").map_err(to_py)?;
    map_f64_rows(py, dirs, "dirs", |d: [f64; 3]| {
        let (x, y) = p.dir_to_pixel(d, size, sg);
        [x, y]
    })
}

#[pyfunction]
fn pixel_to_dir<'py>(
    py: Python<'py>,
    xy: &Bound<'py, PyAny>,
    size: &Bound<'py, PyAny>,
    preset: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let size = image_side("size", positive(size, "size")?)?;
    let p = SpherePreset::by_name(preset).map_err(to_py)?;
    map_f64_rows(py, xy, "xy", |q: [f64; 2]| {
        p.pixel_to_dir(q[0], q[1], size).unwrap_or([f64::NAN; 3])
    })
}

/// (name, doc, frame (3x3 row-major), rows ("top-is-t1"/"top-is-t0"), v_down) of a preset.
type PresetTuple = (String, String, [[f64; 3]; 3], String, bool);

#[pyfunction]
fn presets() -> Vec<PresetTuple> {
    spheremap::PRESETS
        .iter()
        .map(|p| {
            let rows = match p.rows {
                spheremap::RowOrder::TopIsT1 => "top-is-t1",
                spheremap::RowOrder::TopIsT0 => "top-is-t0",
            };
            (
                p.name.to_string(),
                p.doc.to_string(),
                p.frame,
                rows.to_string(),
                p.v_down,
            )
        })
        .collect()
}

/// A mapping by name (the core's [`spheremap::Mapping`]).
fn parse_mapping(mapping: &str, preset: Option<&str>) -> PyResult<spheremap::Mapping> {
    spheremap::Mapping::parse(mapping, preset).map_err(to_py)
}

#[pyfunction]
#[pyo3(signature = (dirs, mapping, preset=None))]
fn dir_to_uv<'py>(
    py: Python<'py>,
    dirs: &Bound<'py, PyAny>,
    mapping: &str,
    preset: Option<&str>,
) -> PyResult<Bound<'py, PyAny>> {
    let m = parse_mapping(mapping, preset)?;
    map_f64_rows(py, dirs, "dirs", |d: [f64; 3]| m.dir_to_uv(d))
}

#[pyfunction]
#[pyo3(signature = (uv, mapping, preset=None))]
fn uv_to_dir<'py>(
    py: Python<'py>,
    uv: &Bound<'py, PyAny>,
    mapping: &str,
    preset: Option<&str>,
) -> PyResult<Bound<'py, PyAny>> {
    let m = parse_mapping(mapping, preset)?;
    map_f64_rows(py, uv, "uv", |q: [f64; 2]| {
        m.uv_to_dir(q).unwrap_or([f64::NAN; 3])
    })
}

/// Exact texel solid angles of a `height`×`width` canvas of `mapping` (cube: the F×6F stack);
/// `height` defaults to the mapping's canvas for that width (lat-long W/2, cube 6W).
#[pyfunction]
#[pyo3(signature = (mapping, width, height=None, preset=None))]
fn texel_solid_angles<'py>(
    py: Python<'py>,
    mapping: &str,
    width: &Bound<'py, PyAny>,
    height: Option<&Bound<'py, PyAny>>,
    preset: Option<&str>,
) -> PyResult<Bound<'py, PyAny>> {
    let m = parse_mapping(mapping, preset)?;
    let width = image_side("width", positive(width, "width")?)?;
    let height = match height {
        Some(h) => positive(h, "height")?,
        None => {
            let (w1, h1) = m.canvas(1);
            (width * h1 / w1).max(1)
        }
    };
    image_side("height", height)?;
    m.size_of(width, height, "height")
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let v = py.detach(|| m.solid_angles(width, height));
    Ok(PyArray1::from_vec(py, v)
        .reshape([height, width])?
        .into_any())
}

/// A core request read from a dict of its fields (Python's keywords) by the core's
/// [`spheremap::jobs::fields::read`]: an error names the field at fault, as a recipe's does.
pub(crate) fn request_of<T>(request: &Bound<'_, PyAny>) -> PyResult<T>
where
    T: serde::de::DeserializeOwned + serde::Serialize + Default,
{
    let fields: serde_json::Value = pythonize::depythonize(request)
        .map_err(|e| PyValueError::new_err(format!("request: {e}")))?;
    spheremap::jobs::fields::read(&fields, &[]).map_err(to_py)
}

/// The names of `kind` as the core lists them ([`spheremap::names`]; Python's FILTERS,
/// CUBE_LAYOUTS, ... are these).
#[pyfunction]
fn names(kind: &str) -> PyResult<Vec<&'static str>> {
    spheremap::names::list(kind)
        .map(|n| n.to_vec())
        .ok_or_else(|| PyValueError::new_err(format!("kind: unknown {kind:?}")))
}

/// A request's documented defaults by operation ([`spheremap::jobs::defaults::of`]), as a dict.
#[pyfunction]
fn defaults<'py>(py: Python<'py>, op: &str) -> PyResult<Bound<'py, PyAny>> {
    let v = spheremap::jobs::defaults::of(op)
        .ok_or_else(|| PyValueError::new_err(format!("op: unknown operation {op:?}")))?;
    pythonize::pythonize(py, &v).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The older spellings of the source's fields, (alias, field)
/// ([`spheremap::jobs::source::ALIASES`]).
#[pyfunction]
fn source_aliases() -> Vec<(&'static str, &'static str)> {
    spheremap::jobs::source::ALIASES.to_vec()
}

/// The core's table of limits ([`spheremap::base::limits::table`]): Python's `limits()`.
#[pyfunction]
fn limits(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    pythonize::pythonize(py, &spheremap::base::limits::table())
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Checks `value` as a name of `kind` with the core's own parser (its aliases included) and
/// returns it; the error names the Python argument `arg`.
#[pyfunction]
fn check_name(kind: &str, value: &str, arg: &str) -> PyResult<String> {
    spheremap::names::check(kind, value, arg)
        .map(|()| value.to_string())
        .map_err(to_py)
}

/// Converts `image` as `job` says: `job` is a `ConvertJob` (the core's conversion request) as a
/// dict of its fields; `image` the source in its mapping (a cube map as faces, their stack or
/// one image in a layout), read by the job's source fields and NaN/Inf rule.  Into `out` when
/// given ((H', W', C), or (6, N, N, C) for a cube), which is returned; else a new array (a
/// cube's as its faces).  Runs on a worker thread; Ctrl-C (KeyboardInterrupt) cancels it.
#[pyfunction]
#[pyo3(signature = (image, job, out=None))]
fn convert<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    job: &Bound<'py, PyAny>,
    out: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    use spheremap::jobs::convert::ConvertJob;
    use spheremap::resample::Progress;
    let job: ConvertJob = request_of(job)?;
    let named = |e: spheremap::Error| to_py(python_names(e));
    let r = job.resolve(None, "image").map_err(named)?;
    let (cube, layout) = (r.src.name() == "cube", r.from_layout.map(|l| l.name()));
    let img = args::env_arg_with(image, cube, layout, "image", job.nonfinite)?;
    let progress = Progress::default();
    if let Some(out) = out {
        let np = py.import("numpy")?;
        if np
            .call_method1("shares_memory", (&out, image))?
            .is_truthy()?
        {
            return Err(PyValueError::new_err("out: overlaps image"));
        }
        let arr = out.cast_into::<PyArrayDyn<f32>>().map_err(|e| {
            let got = e.into_inner().get_type().name().map(|n| n.to_string());
            PyValueError::new_err(format!(
                "out: expected a float32 numpy array, got {}",
                got.unwrap_or_default()
            ))
        })?;
        // The caller's buffer: (H', W', C) float32, C-contiguous, writeable (for a cube also
        // (6, N, N, C)); the result is written into it and it is returned.
        let n = job
            .size_for(
                &r,
                r.src
                    .size_of(img.width, img.height, "image")
                    .map_err(named)?,
            )
            .map_err(named)?;
        let (dw, dh) = r.dst.canvas(n);
        let c = img.channels;
        let shape = arr.shape().to_vec();
        let (plain, faces) = ([dh, dw, c], [6, dw, dw, c]);
        let cube = r.dst.name() == "cube";
        if shape != plain && !(cube && shape == faces) {
            let want: &[usize] = if cube { &faces } else { &plain };
            return Err(PyValueError::new_err(format!(
                "out: expected shape {}, got {}",
                args::shape_text(want),
                args::shape_text(&shape)
            )));
        }
        {
            let mut rw = arr
                .try_readwrite()
                .map_err(|e| PyValueError::new_err(format!("out: {e}")))?;
            let buf = rw
                .as_slice_mut()
                .map_err(|_| PyValueError::new_err("out: must be C-contiguous".to_string()))?;
            run_cancellable(py, &progress, "the conversion", |p| {
                job.run_image(&img, Some(p), Some(buf))
                    .map_err(python_names)
            })?;
        }
        emit_warnings(py)?;
        return Ok(arr.into_any());
    }
    let (img, _, _) = run_cancellable(py, &progress, "the conversion", |p| {
        job.run_image(&img, Some(p), None).map_err(python_names)
    })?;
    emit_warnings(py)?;
    image_out(
        py,
        img.expect("no buffer given: a new image"),
        r.dst.name() == "cube",
    )
}

/// An environment argument of a request that reads one through `source`, with its NaN/Inf
/// rule; errors name `name`.
fn source_arg(
    ob: &Bound<'_, PyAny>,
    source: &spheremap::jobs::source::Source,
    nonfinite: spheremap::images::codec::NonFinite,
    name: &str,
) -> PyResult<spheremap::images::Image> {
    let r = source.resolve(None, name, Some("latlong")).map_err(to_py)?;
    args::env_arg_with(
        ob,
        r.mapping.name() == "cube",
        r.layout.map(|l| l.name()),
        name,
        nonfinite,
    )
}

/// Bakes a MatCap: `request` is a `MatcapRequest` (the core's bake request) as a dict of its
/// fields; `image` the environment ((H, W, C), a cube map as its face stack).  -> (N, N, C).
#[pyfunction]
#[pyo3(signature = (image, request))]
fn bake_matcap<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    request: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    use spheremap::jobs::bake_matcap::MatcapRequest;
    use spheremap::resample::Progress;
    let req: MatcapRequest = request_of(request)?;
    let img = source_arg(image, &req.source, req.nonfinite, "env")?;
    let progress = Progress::default();
    let (out, _) = run_cancellable(py, &progress, "the bake", |p| req.run_image(&img, Some(p)))?;
    image_out(py, out, false)
}

/// Arrays and their report dicts.
type PyLevels<'py> = (Vec<Bound<'py, PyAny>>, Vec<Bound<'py, PyAny>>);

/// The prefiltered levels of an environment array (level 0 first; a cube's as its (6, F, F, C)
/// faces) and their reports as dicts; `request` is a `PrefilterRequest` as a dict.
#[pyfunction]
#[pyo3(signature = (image, request))]
fn prefilter<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    request: &Bound<'py, PyAny>,
) -> PyResult<PyLevels<'py>> {
    use spheremap::jobs::prefilter::PrefilterRequest;
    use spheremap::resample::Progress;
    let req: PrefilterRequest = request_of(request)?;
    let img = source_arg(image, &req.source, req.nonfinite, "env")?;
    let cube =
        spheremap::Mapping::parse(&req.to, req.preset.as_deref()).is_ok_and(|m| m.name() == "cube");
    let progress = Progress::default();
    let made = run_cancellable(py, &progress, "the prefilter", |p| {
        req.run_image(&img, Some(p))
    })?;
    let (mut arrays, mut reports) = (Vec::new(), Vec::new());
    for (out, rep) in made {
        arrays.push(image_out(py, out, cube)?);
        reports.push(
            pythonize::pythonize(py, &rep)
                .map_err(|e| PyValueError::new_err(e.to_string()))?
                .into_any(),
        );
    }
    Ok((arrays, reports))
}

/// The pixel limit of a read: `max_pixels` when given, else the core's.
fn read_limits(
    max_pixels: Option<&Bound<'_, PyAny>>,
) -> PyResult<spheremap::images::codec::Limits> {
    let mut limits = spheremap::images::codec::Limits::default();
    if let Some(m) = max_pixels {
        limits.max_pixels = positive(m, "max_pixels")?;
    }
    Ok(limits)
}

/// Reads a KTX2 or DDS texture: (levels as (H, W, C) float32 arrays, level 0 first; whether it
/// is a cube, whose levels are (6, F, F, C) faces).
#[pyfunction]
#[pyo3(signature = (path, max_pixels=None))]
fn read_texture<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    max_pixels: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Vec<Bound<'py, PyAny>>, bool)> {
    use spheremap::images::codec::ReadOptions;
    let limits = read_limits(max_pixels)?;
    let tex = py
        .detach(|| {
            spheremap::images::codec::read_texture(
                &path,
                &ReadOptions {
                    linear: true,
                    limits,
                },
            )
        })
        .map_err(to_py)?;
    let levels = tex
        .levels
        .into_iter()
        .map(|l| image_out(py, l, tex.cube))
        .collect::<PyResult<Vec<_>>>()?;
    Ok((levels, tex.cube))
}

/// Writes levels (level 0 first, each (H, W[, C]); a cube's as faces, their stack or one image
/// in a layout) as a KTX2 or DDS texture;
/// with an `encode` other than "float", returns what encoding did to each level's light (a
/// list of dicts), else None.
#[pyfunction]
#[pyo3(signature = (path, levels, cube, half, clamp_half, note, encode, zstd))]
#[allow(clippy::too_many_arguments)]
fn write_texture<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    levels: Vec<Bound<'py, PyAny>>,
    cube: bool,
    half: bool,
    clamp_half: bool,
    note: Option<String>,
    encode: String,
    zstd: Option<i32>,
) -> PyResult<Bound<'py, PyAny>> {
    use spheremap::images::codec::WriteOptions;
    let levels = levels
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let name = format!("levels[{i}]");
            let a = FArr::extract(a, &name)?;
            spheremap::images::cube_layout::env_array(&a.shape(), a.to_f32(), cube, None, &name)
                .map_err(to_py)
        })
        .collect::<PyResult<Vec<_>>>()?;
    let tex = spheremap::images::container::Texture { cube, levels };
    let encode =
        spheremap::images::compress::Encoding::parse_as(&encode, "encode").map_err(to_py)?;
    let opts = WriteOptions {
        half,
        clamp_half,
        encode,
        zstd,
        ..Default::default()
    };
    let report = py.detach(|| {
        tex.check("levels")?;
        spheremap::images::codec::write_texture(&path, &tex, &opts, note.as_deref())
    });
    emit_warnings(py)?;
    let report = report.map_err(to_py)?;
    pythonize::pythonize(py, &report).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The SH9 report of `spheremap irradiance --json` for an environment array, as a dict;
/// `request` is an `IrradianceRequest` (`jobs::irradiance`) as a dict.
#[pyfunction]
#[pyo3(signature = (image, request))]
fn irradiance_sh<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    request: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let req: spheremap::jobs::irradiance::IrradianceRequest = request_of(request)?;
    let img = source_arg(image, &req.source, req.nonfinite, "env")?;
    let r = req.resolve(None, "env").map_err(to_py)?;
    let env = spheremap::resample::EnvMap::from_slice(
        r.env.mapping,
        img.width,
        img.height,
        img.channels,
        &img.data,
        "env",
    )
    .map_err(to_py)?;
    let report = py.detach(|| r.report(&env, "env")).map_err(to_py)?;
    Ok(pythonize::pythonize(py, &report)
        .map_err(|e| PyValueError::new_err(format!("report: {e}")))?
        .into_any())
}

/// The split-sum DFG table (N, N, 3) float32: A, B, A + B; `request`: a `DfgRequest`'s fields.
#[pyfunction]
#[pyo3(signature = (request))]
fn dfg_lut<'py>(py: Python<'py>, request: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let req: spheremap::jobs::dfg::DfgRequest = request_of(request)?;
    let img = py.detach(|| req.run_image()).map_err(to_py)?;
    Ok(PyArray1::from_vec(py, img.data)
        .reshape([img.height, img.width, 3])?
        .into_any())
}

/// A conversion request's output fields as Python's `convert` spells its arguments (`dst`,
/// `dst_preset`; the source's, `src`, `src_preset`, …, are spelled alike).
fn python_names(e: spheremap::Error) -> spheremap::Error {
    match e {
        spheremap::Error::InvalidParameter { name, reason } => {
            let py_name = match name.as_str() {
                "to" => "dst",
                "preset" => "dst_preset",
                other => other,
            };
            spheremap::Error::param(py_name, reason)
        }
        other => other,
    }
}

/// Runs `work` on a worker thread with the GIL released, waking every 20 ms so Python sees
/// Ctrl-C (which sets `progress.cancel`; the work stops and the KeyboardInterrupt is raised).
/// A panic in the worker becomes an exception instead of killing the interpreter.
fn run_cancellable<T: Send>(
    py: Python<'_>,
    progress: &spheremap::resample::Progress,
    what: &str,
    work: impl FnOnce(&spheremap::resample::Progress) -> spheremap::Result<T> + Send,
) -> PyResult<T> {
    use std::sync::atomic::Ordering;
    let mut interrupted: Option<PyErr> = None;
    let result = py.detach(|| {
        std::thread::scope(|s| {
            let (tx, rx) = std::sync::mpsc::channel();
            s.spawn(move || {
                let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(progress)));
                let _ = tx.send(r);
            });
            loop {
                match rx.recv_timeout(std::time::Duration::from_millis(20)) {
                    Ok(r) => return Some(r),
                    Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                        if interrupted.is_none() {
                            if let Err(e) = Python::attach(|py| py.check_signals()) {
                                progress.cancel.store(true, Ordering::Relaxed);
                                interrupted = Some(e);
                            }
                        }
                    }
                    Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => return None,
                }
            }
        })
    });
    if let Some(e) = interrupted {
        return Err(e);
    }
    match result {
        Some(Ok(r)) => r.map_err(to_py),
        _ => Err(PyValueError::new_err(format!(
            "internal error: {what} panicked (a bug; please report it)"
        ))),
    }
}

/// An environment map array as the core reads it ([`spheremap::images::cube_layout::env_array`]):
/// (H, W, C) float32; a cube map (`cube`), given as faces, a stack or one image in `layout` (or
/// the layout its shape implies), as its (6, F, F, C) faces.
#[pyfunction]
#[pyo3(signature = (image, cube, layout, name))]
fn env_array<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    cube: bool,
    layout: Option<&str>,
    name: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let a = FArr::extract(image, name)?;
    let img = spheremap::images::cube_layout::env_array(&a.shape(), a.to_f32(), cube, layout, name)
        .map_err(to_py)?;
    image_out(py, img, cube)
}

/// A cube map's faces (6, F, F[, C]), in GL order, as one image in `layout`.
#[pyfunction]
fn stack_to_layout<'py>(
    py: Python<'py>,
    faces: &Bound<'py, PyAny>,
    layout: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let l = spheremap::images::cube_layout::Layout::parse(layout).map_err(to_py)?;
    let a = FArr::extract(faces, "faces")?;
    let shape = a.shape();
    if !matches!(shape.as_slice(), [6, f, g] | [6, f, g, _] if f == g) {
        return Err(PyValueError::new_err(format!(
            "faces: expected (6, F, F, C) with C in 1..4, got shape {}",
            args::shape_text(&shape)
        )));
    }
    let img = spheremap::images::cube_layout::env_array(&shape, a.to_f32(), true, None, "faces")
        .map_err(to_py)?;
    image_out(py, l.from_stack(&img).map_err(to_py)?, false)
}

/// Reads an image file -> (H, W, C) float32, linear, row 0 at the top.
#[pyfunction]
#[pyo3(signature = (path, linear, max_pixels=None))]
fn read_image<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    linear: bool,
    max_pixels: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    use spheremap::images::codec::ReadOptions;
    let limits = read_limits(max_pixels)?;
    let img =
        py.detach(|| spheremap::images::codec::read_image(&path, &ReadOptions { linear, limits }));
    emit_warnings(py)?;
    image_out(py, img.map_err(to_py)?, false)
}

/// Describes an image file: what `spheremap info --json` prints, as a dict; `request` is an
/// `InfoRequest`'s fields.
#[pyfunction]
#[pyo3(signature = (path, request))]
fn info<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    request: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let req: spheremap::jobs::info::InfoRequest = request_of(request)?;
    let report = py.detach(|| req.run_files(&path)).map_err(to_py)?;
    Ok(pythonize::pythonize(py, &report)?)
}

/// Writes an (H, W[, C]) array (C in 1..=4) to `path`; the format follows the extension.
/// Returns what the format lost: {"clipped", "clamped_half"}.
#[pyfunction]
#[pyo3(signature = (path, array, linear, bits, half, clamp_half, note, encode))]
#[allow(clippy::too_many_arguments)]
fn write_image(
    py: Python<'_>,
    path: std::path::PathBuf,
    array: &Bound<'_, PyAny>,
    linear: bool,
    bits: u32,
    half: bool,
    clamp_half: bool,
    note: Option<String>,
    encode: String,
) -> PyResult<std::collections::BTreeMap<&'static str, u64>> {
    use spheremap::images::codec::{Losses, WriteOptions};
    use spheremap::images::format::Format;
    let img = image_arg(array, "array")?;
    if bits != 8 && bits != 16 {
        return Err(PyValueError::new_err(format!(
            "bits: must be 8 or 16, got {bits}"
        )));
    }
    let png16 = bits == 16;
    let encode =
        spheremap::images::compress::Encoding::parse_as(&encode, "encode").map_err(to_py)?;
    let opts = WriteOptions {
        linear,
        png16,
        half,
        clamp_half,
        encode,
        ..Default::default()
    };
    let done = py.detach(|| {
        spheremap::images::codec::write_image_with_note(&path, &img, &opts, note.as_deref())?;
        let l = Format::from_extension(&path)
            .map(|f| Losses::of(&img, f, &opts))
            .unwrap_or_default();
        Ok([("clipped", l.clipped), ("clamped_half", l.beyond_half)].into())
    });
    emit_warnings(py)?;
    done.map_err(to_py)
}

/// The note ([`spheremap::images::note`]) that records a map's mapping, preset, cube layout and
/// view, or None; `request`: a `NoteRequest`'s fields, checked by the core.
#[pyfunction]
#[pyo3(signature = (request))]
fn map_note(request: &Bound<'_, PyAny>) -> PyResult<Option<String>> {
    let req: spheremap::images::note::NoteRequest = request_of(request)?;
    Ok(req.resolve().map_err(to_py)?.map(|n| n.text()))
}

/// Runs the command line (one definition, in Rust) with `argv` (argv[0] = program name).
/// Ctrl-C reaches the command as its cancel flag (it then exits 2 without writing).
#[pyfunction]
fn _cli_main(py: Python<'_>, argv: Vec<String>) -> i32 {
    use std::sync::atomic::Ordering;
    // Cleared here, before the command starts, and never inside it: a Ctrl-C that arrives
    // while the arguments are parsed must still cancel (clearing it in the worker lost such
    // an interrupt, and the command then ran to the end). The flag is process-wide, so a
    // previous in-process call's interrupt is forgotten only at this point.
    spheremap_cli::progress::INTERRUPTED.store(false, Ordering::SeqCst);
    py.detach(|| {
        std::thread::scope(|s| {
            let worker = s.spawn(|| spheremap_cli::main_with_args(argv));
            while !worker.is_finished() {
                std::thread::sleep(std::time::Duration::from_millis(20));
                if Python::attach(|py| py.check_signals()).is_err() {
                    spheremap_cli::progress::INTERRUPTED.store(true, Ordering::SeqCst);
                }
            }
            worker.join().unwrap_or(2)
        })
    })
}

#[pymodule]
fn _spheremap(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Panics the core catches inside third-party parsers (guard_parser) are errors, not
    // messages: keep the default hook quiet for them.
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !spheremap::base::error::panic_is_guarded() {
            previous(info)
        }
    }));
    spheremap::base::error::set_warning_sink(Some(queue_warning));
    m.add("__version__", spheremap::VERSION)?;
    m.add("MAX_SPLIT", spheremap::jobs::analyze::MAX_SPLIT)?;
    m.add("VIEW_MAX_UPLOAD", spheremap::base::limits::UPLOAD_BYTES)?;
    m.add("Error", m.py().get_type::<Error>())?;
    m.add("DataError", m.py().get_type::<DataError>())?;
    m.add("UnsupportedError", m.py().get_type::<UnsupportedError>())?;
    m.add("LimitError", m.py().get_type::<LimitError>())?;
    m.add_class::<view::ViewServer>()?;
    m.add_function(wrap_pyfunction!(batch::_batch_recipe, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_batch_plan, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_batch_prepare, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_batch_run_task, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_batch_append, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_batch_failed_record, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_batch_run_local, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_batch_summary, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_batch_read_manifest, m)?)?;
    m.add_function(wrap_pyfunction!(batch::_batch_report, m)?)?;
    m.add_class::<batch::BatchProgress>()?;
    m.add_function(wrap_pyfunction!(names, m)?)?;
    m.add_function(wrap_pyfunction!(source_aliases, m)?)?;
    m.add_function(wrap_pyfunction!(defaults, m)?)?;
    m.add_function(wrap_pyfunction!(limits, m)?)?;
    m.add_function(wrap_pyfunction!(check_name, m)?)?;
    m.add_function(wrap_pyfunction!(sphere_texgen, m)?)?;
    m.add_function(wrap_pyfunction!(dir_to_sphere, m)?)?;
    m.add_function(wrap_pyfunction!(sphere_to_dir, m)?)?;
    m.add_function(wrap_pyfunction!(reflect, m)?)?;
    m.add_function(wrap_pyfunction!(matcap_uv, m)?)?;
    m.add_function(wrap_pyfunction!(sphere_texel_solid_angle, m)?)?;
    m.add_function(wrap_pyfunction!(dir_to_pixel, m)?)?;
    m.add_function(wrap_pyfunction!(pixel_to_dir, m)?)?;
    m.add_function(wrap_pyfunction!(presets, m)?)?;
    m.add_function(wrap_pyfunction!(dir_to_uv, m)?)?;
    m.add_function(wrap_pyfunction!(uv_to_dir, m)?)?;
    m.add_function(wrap_pyfunction!(texel_solid_angles, m)?)?;
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    m.add_function(wrap_pyfunction!(info, m)?)?;
    m.add_function(wrap_pyfunction!(map_note, m)?)?;
    m.add_function(wrap_pyfunction!(convert, m)?)?;
    m.add_function(wrap_pyfunction!(bake_matcap, m)?)?;
    m.add_function(wrap_pyfunction!(irradiance_sh, m)?)?;
    m.add_function(wrap_pyfunction!(dfg_lut, m)?)?;
    m.add_function(wrap_pyfunction!(prefilter, m)?)?;
    m.add_function(wrap_pyfunction!(read_texture, m)?)?;
    m.add_function(wrap_pyfunction!(write_texture, m)?)?;
    m.add_function(wrap_pyfunction!(env_array, m)?)?;
    m.add_function(wrap_pyfunction!(stack_to_layout, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    m.add_function(wrap_pyfunction!(_cli_main, m)?)?;
    m.add_class::<generate::Scene>()?;
    m.add_function(wrap_pyfunction!(generate::generate, m)?)?;
    m.add_function(wrap_pyfunction!(photo::from_mirror_ball, m)?)?;
    m.add_function(wrap_pyfunction!(photo::from_fisheye, m)?)?;
    m.add_function(wrap_pyfunction!(photo::find_ball, m)?)?;
    m.add_function(wrap_pyfunction!(photo::render_camera, m)?)?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::load_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(render::analyze, m)?)?;
    Ok(())
}
