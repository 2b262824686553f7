//! Python arguments as the core takes them, and arrays back: any array-like as a float32 or
//! float64 C-contiguous array (other sequences read as float64), images (H, W[, C]),
//! environment maps by the core's rules, positive integers, and images returned as arrays (a
//! cube map as its (6, F, F, C) faces).  Every error names the argument.

use numpy::{
    PyArray1, PyArrayDescrMethods, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use spheremap::images::codec::{check_nonfinite, NonFinite};
use spheremap::images::cube_layout::env_array;
use spheremap::images::Image;

use super::to_py;

/// A float32 or float64 C-contiguous array.
pub(crate) enum FArr<'py> {
    F32(PyReadonlyArrayDyn<'py, f32>),
    F64(PyReadonlyArrayDyn<'py, f64>),
}

fn value_error(name: &str, what: String) -> PyErr {
    PyValueError::new_err(format!("{name}: {what}"))
}

/// A shape as Python writes it: `(4, 3)`, `(4,)`.
pub(crate) fn shape_text(shape: &[usize]) -> String {
    match shape {
        [one] => format!("({one},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

impl<'py> FArr<'py> {
    /// `ob` as a float32/float64 C-contiguous array: a numpy array of either dtype as it is
    /// (copied only when not C-contiguous), anything else read by `numpy.asarray` as float64.
    pub(crate) fn extract(ob: &Bound<'py, PyAny>, name: &str) -> PyResult<Self> {
        let np = ob.py().import("numpy")?;
        let a = if ob.is_instance_of::<PyUntypedArray>() {
            ob.clone()
        } else {
            np.call_method1("asarray", (ob, "float64")).map_err(|e| {
                value_error(name, format!("cannot be read as an array of numbers ({e})"))
            })?
        };
        let u = a.cast::<PyUntypedArray>()?;
        let dtype = u.dtype();
        let (f32, f64) = (
            dtype.is_equiv_to(&numpy::dtype::<f32>(ob.py())),
            dtype.is_equiv_to(&numpy::dtype::<f64>(ob.py())),
        );
        if !f32 && !f64 {
            return Err(value_error(
                name,
                format!("dtype {dtype} is not supported; pass float32 or float64"),
            ));
        }
        if u.ndim() == 0 {
            return Err(value_error(name, "expected an array, got a scalar".into()));
        }
        let a = if u.is_c_contiguous() {
            a
        } else {
            np.call_method1("ascontiguousarray", (&a,))?
        };
        Ok(if f32 {
            FArr::F32(a.extract()?)
        } else {
            FArr::F64(a.extract()?)
        })
    }

    pub(crate) fn shape(&self) -> Vec<usize> {
        match self {
            FArr::F32(a) => a.shape().to_vec(),
            FArr::F64(a) => a.shape().to_vec(),
        }
    }

    /// The values, row-major, as float32 (float64 rounded).
    pub(crate) fn to_f32(&self) -> Vec<f32> {
        match self {
            FArr::F32(a) => a.as_slice().expect("C-contiguous").to_vec(),
            FArr::F64(a) => a
                .as_slice()
                .expect("C-contiguous")
                .iter()
                .map(|&v| v as f32)
                .collect(),
        }
    }

    /// The values, row-major, as float64.
    pub(crate) fn to_f64(&self) -> Vec<f64> {
        match self {
            FArr::F32(a) => a
                .as_slice()
                .expect("C-contiguous")
                .iter()
                .map(|&v| v as f64)
                .collect(),
            FArr::F64(a) => a.as_slice().expect("C-contiguous").to_vec(),
        }
    }

    /// Refuses a shape whose number of dimensions is not `ndim` (when given) or whose last
    /// dimension is none of `last`.
    pub(crate) fn check(&self, name: &str, ndim: Option<usize>, last: &[usize]) -> PyResult<()> {
        let shape = self.shape();
        if let Some(n) = ndim {
            if shape.len() != n {
                return Err(value_error(
                    name,
                    format!("expected a {n}-D array, got shape {}", shape_text(&shape)),
                ));
            }
        }
        if !last.is_empty() && !last.contains(shape.last().expect("not a scalar")) {
            let want: Vec<String> = last.iter().map(|v| v.to_string()).collect();
            return Err(value_error(
                name,
                format!(
                    "last dimension must be {}, got shape {}",
                    want.join(" or "),
                    shape_text(&shape)
                ),
            ));
        }
        Ok(())
    }
}

/// Rows of `cols` values ((K, cols) arrays, e.g. ray origins) as float32.
pub(crate) fn rows_f32(ob: &Bound<'_, PyAny>, name: &str, cols: usize) -> PyResult<Vec<f32>> {
    let a = FArr::extract(ob, name)?;
    a.check(name, Some(2), &[cols])?;
    Ok(a.to_f32())
}

/// An image argument: (H, W) or (H, W, C) with C in 1..4 (the core's rule), as float32.
pub(crate) fn image_arg(ob: &Bound<'_, PyAny>, name: &str) -> PyResult<Image> {
    let a = FArr::extract(ob, name)?;
    env_array(&a.shape(), a.to_f32(), false, None, name).map_err(to_py)
}

/// An environment map argument as the core reads arrays ([`env_array`]: a cube map given as
/// faces, their stack or one image in `layout` or the layout its shape implies, becomes the
/// stack), refused when it holds NaN or Inf.
pub(crate) fn env_arg(
    ob: &Bound<'_, PyAny>,
    cube: bool,
    layout: Option<&str>,
    name: &str,
) -> PyResult<Image> {
    env_arg_with(ob, cube, layout, name, NonFinite::Error)
}

/// [`env_arg`] with the NaN/Inf policy `nonfinite`.
pub(crate) fn env_arg_with(
    ob: &Bound<'_, PyAny>,
    cube: bool,
    layout: Option<&str>,
    name: &str,
    nonfinite: NonFinite,
) -> PyResult<Image> {
    let a = FArr::extract(ob, name)?;
    let mut img = env_array(&a.shape(), a.to_f32(), cube, layout, name).map_err(to_py)?;
    check_nonfinite(&mut img, nonfinite, name).map_err(to_py)?;
    Ok(img)
}

/// An integer argument (not a bool) of at least `min`, else an error saying what it expected.
fn integer(ob: &Bound<'_, PyAny>, name: &str, min: u64, what: &str) -> PyResult<u64> {
    match ob.extract::<u64>() {
        Ok(v) if v >= min && !ob.is_instance_of::<pyo3::types::PyBool>() => Ok(v),
        _ => {
            let repr = ob.repr().map(|r| r.to_string()).unwrap_or_default();
            Err(value_error(name, format!("expected {what}, got {repr}")))
        }
    }
}

/// A positive integer argument (not a bool).
pub(crate) fn positive(ob: &Bound<'_, PyAny>, name: &str) -> PyResult<usize> {
    integer(ob, name, 1, "a positive integer").map(|v| v as usize)
}

/// A non-negative integer argument (not a bool).
pub(crate) fn nonnegative(ob: &Bound<'_, PyAny>, name: &str) -> PyResult<u64> {
    integer(ob, name, 0, "a non-negative integer")
}

/// An image as a float32 array: (H, W, C), or with `faces` a cube map's (6F, F, C) stack as
/// its (6, F, F, C) faces.
pub(crate) fn image_out<'py>(
    py: Python<'py>,
    img: Image,
    faces: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let a = PyArray1::from_vec(py, img.data);
    Ok(if faces {
        a.reshape([6, img.width, img.width, img.channels])?
            .into_any()
    } else {
        a.reshape([img.height, img.width, img.channels])?.into_any()
    })
}

/// Three finite numbers (a point, a direction, an RGB colour).
pub(crate) fn vec3(ob: &Bound<'_, PyAny>, name: &str) -> PyResult<[f32; 3]> {
    let a = FArr::extract(ob, name)?;
    let v = a.to_f64();
    if a.shape() != [3] || !v.iter().all(|x| x.is_finite()) {
        let repr = ob.repr().map(|r| r.to_string()).unwrap_or_default();
        return Err(value_error(
            name,
            format!("expected 3 finite numbers, got {repr}"),
        ));
    }
    Ok([v[0] as f32, v[1] as f32, v[2] as f32])
}

/// An optional path argument (a str or an os.PathLike; None).
pub(crate) fn path_arg(
    ob: Option<&Bound<'_, PyAny>>,
    name: &str,
) -> PyResult<Option<std::path::PathBuf>> {
    let Some(ob) = ob.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    ob.extract().map(Some).map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "{name}: expected a path or None, got {}",
            ob.get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_default()
        ))
    })
}
