//! PyO3 glue for the ray-traced generator: the `Scene` class and `generate` with a scene or a
//! Python callable as `fire_ray`.  No maths here.

use super::{run_cancellable, to_py};
use numpy::{
    PyArray1, PyArrayMethods, PyReadonlyArray2, PyReadonlyArrayDyn, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
use spheremap::resample::{self as rs, Progress};
use spheremap::trace::generate::RaySource;
use spheremap::trace::scene::{self, Environment, Light, Shading};
use std::sync::Mutex;

/// A ray-traced scene (see the README): callable as `fire_ray(origins, directions)`.
#[pyclass(module = "spheremap._spheremap", name = "Scene")]
pub struct Scene {
    inner: scene::Scene,
}

fn rgb(v: Vec<f32>, name: &str) -> PyResult<[f32; 3]> {
    match v.as_slice() {
        [r, g, b] if v.iter().all(|x| x.is_finite()) => Ok([*r, *g, *b]),
        _ => Err(PyValueError::new_err(format!(
            "{name}: expected 3 finite numbers"
        ))),
    }
}

impl Scene {
    /// The core scene (for the other glue modules).
    pub(crate) fn inner(&self) -> &scene::Scene {
        &self.inner
    }
}

#[pymethods]
impl Scene {
    /// Loads an OBJ (+MTL) or glTF 2.0 file.
    #[staticmethod]
    fn load(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Scene> {
        let inner = py.detach(|| scene::Scene::load(&path));
        crate::emit_warnings(py)?;
        let inner = inner.map_err(to_py)?;
        Ok(Scene { inner })
    }

    /// A built-in scene: "demo", "octants" or "mirror-ball" (of `reflectance`).
    #[staticmethod]
    #[pyo3(signature = (name, reflectance = 0.75))]
    fn builtin(name: &str, reflectance: f32) -> PyResult<Scene> {
        let inner = scene::Builtin::parse(name)
            .map_err(to_py)?
            .scene(reflectance)
            .map_err(to_py)?;
        Ok(Scene { inner })
    }

    #[getter]
    fn triangle_count(&self) -> usize {
        self.inner.triangle_count()
    }

    #[getter]
    fn light_count(&self) -> usize {
        self.inner.lights.len()
    }

    #[getter]
    fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        self.inner.bounds()
    }

    fn set_background(&mut self, colour: Vec<f32>) -> PyResult<()> {
        self.inner.environment = Environment::Constant(rgb(colour, "background")?);
        Ok(())
    }

    /// An environment map (H, W, C) float32 (cube: the (6F, F, C) face stack) read as
    /// `request` says (an `EnvRequest` as a dict: `src`, `src_preset`, `src_look`, `src_up`).
    #[pyo3(signature = (image, request))]
    fn set_environment(
        &mut self,
        image: PyReadonlyArrayDyn<'_, f32>,
        request: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let req: spheremap::jobs::source::EnvRequest = super::request_of(request)?;
        let r = req.resolve(None, "environment").map_err(to_py)?;
        let img = super::image_of(&image, "environment")?;
        rs::EnvMap::new(r.mapping, &img, "environment").map_err(to_py)?;
        self.inner.environment = Environment::Map {
            image: img,
            mapping: r.mapping,
            rotation: r.world_to_env,
        };
        Ok(())
    }

    fn add_point_light(&mut self, position: Vec<f32>, intensity: Vec<f32>) -> PyResult<()> {
        self.inner.lights.push(Light::Point {
            position: rgb(position, "position")?,
            intensity: rgb(intensity, "intensity")?,
        });
        Ok(())
    }

    fn add_directional_light(&mut self, direction: Vec<f32>, irradiance: Vec<f32>) -> PyResult<()> {
        let d = rgb(direction, "direction")?;
        if d == [0.0; 3] {
            return Err(PyValueError::new_err("direction: must not be zero"));
        }
        self.inner.lights.push(Light::Directional {
            direction: d,
            irradiance: rgb(irradiance, "irradiance")?,
        });
        Ok(())
    }

    fn set_options(
        &mut self,
        shading: &str,
        max_depth: u32,
        indirect_samples: u32,
        seed: u64,
    ) -> PyResult<()> {
        self.inner.options.shading = Shading::parse(shading).map_err(to_py)?;
        self.inner.options.max_depth = max_depth;
        self.inner.options.indirect_samples = indirect_samples;
        self.inner.options.seed = seed;
        Ok(())
    }

    /// Radiance along rays: origins, directions (K, 3) float32 -> (K, 3) float32, in parallel.
    fn trace<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'py, f32>,
        directions: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (o, d) = rays(&origins, &directions)?;
        let mut out = vec![0f32; d.len() * 3];
        py.detach(|| {
            out.par_chunks_mut(3 * 1024)
                .zip(o.par_chunks(1024).zip(d.par_chunks(1024)))
                .try_for_each(|(out, (o, d))| self.inner.trace(o, d, out))
        })
        .map_err(to_py)?;
        Ok(PyArray1::from_vec(py, out)
            .reshape([d.len(), 3])?
            .into_any())
    }

    /// Distance to the closest hit per ray (inf on a miss).
    fn intersect<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'py, f32>,
        directions: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (o, d) = rays(&origins, &directions)?;
        let t: Vec<f32> = py.detach(|| {
            o.par_iter()
                .zip(d.par_iter())
                .with_min_len(1024)
                .map(|(o, d)| self.inner.intersect(*o, *d).unwrap_or(f32::INFINITY))
                .collect()
        });
        Ok(PyArray1::from_vec(py, t).into_any())
    }
}

/// (K, 3) arrays as slices of 3-vectors.
/// Origins and directions as 3-vectors.
type RayPair<'a> = (&'a [[f32; 3]], &'a [[f32; 3]]);

fn rays<'a>(
    o: &'a PyReadonlyArray2<'_, f32>,
    d: &'a PyReadonlyArray2<'_, f32>,
) -> PyResult<RayPair<'a>> {
    let check = |a: &'a PyReadonlyArray2<'_, f32>, name: &str| -> PyResult<&'a [[f32; 3]]> {
        if a.shape()[1] != 3 {
            return Err(PyValueError::new_err(format!(
                "{name}: expected shape (K, 3)"
            )));
        }
        let s = a
            .as_slice()
            .map_err(|_| PyValueError::new_err(format!("{name}: array must be C-contiguous")))?;
        // (K, 3) contiguous f32 is K [f32; 3] in place (no copy).
        Ok(bytemuck::cast_slice(s))
    };
    let (o, d) = (check(o, "origins")?, check(d, "directions")?);
    if o.len() != d.len() {
        return Err(PyValueError::new_err(format!(
            "origins: {} rays but directions has {}",
            o.len(),
            d.len()
        )));
    }
    Ok((o, d))
}

/// A Python callable as the ray source: called with (K, 3) float32 origins and directions
/// (one output row of rays per call, from worker threads that take the GIL in turn); it must
/// return (K, C) float32 (the Python wrapper converts and checks).  The first exception it
/// raises stops the run and is re-raised.
struct CallableSource {
    f: Py<PyAny>,
    channels: usize,
    error: Mutex<Option<PyErr>>,
}

impl RaySource for CallableSource {
    fn channels(&self) -> usize {
        self.channels
    }
    fn trace(
        &self,
        origins: &[[f32; 3]],
        dirs: &[[f32; 3]],
        out: &mut [f32],
    ) -> spheremap::Result<()> {
        let k = dirs.len();
        let r: PyResult<()> = Python::attach(|py| {
            let o = PyArray1::from_slice(py, origins.as_flattened()).reshape([k, 3])?;
            let d = PyArray1::from_slice(py, dirs.as_flattened()).reshape([k, 3])?;
            let res = self.f.call1(py, (o, d))?;
            let arr: PyReadonlyArray2<f32> = res.extract(py)?;
            if arr.shape() != [k, self.channels] {
                return Err(PyValueError::new_err(format!(
                    "fire_ray: returned shape {:?} for {k} rays; expected ({k}, {})",
                    arr.shape(),
                    self.channels
                )));
            }
            out.copy_from_slice(arr.as_slice()?);
            Ok(())
        });
        r.map_err(|e| {
            let msg = e.to_string();
            let mut slot = self.error.lock().unwrap_or_else(|p| p.into_inner());
            slot.get_or_insert(e);
            spheremap::Error::param("fire_ray", msg)
        })
    }
}

#[allow(clippy::too_many_arguments)]
fn run<'py>(
    py: Python<'py>,
    map: &spheremap::trace::generate::ResolvedMap,
    source: &dyn RaySource,
) -> PyResult<Bound<'py, PyAny>> {
    let progress = Progress::default();
    let (img, _) = run_cancellable(py, &progress, "the generation", |p| {
        spheremap::trace::generate::generate(
            map.mapping,
            map.width,
            map.height,
            source,
            &map.options,
            Some(p),
        )
    })?;
    Ok(PyArray1::from_vec(py, img.data)
        .reshape([img.height, img.width, img.channels])?
        .into_any())
}

/// Generates with `source`: a `Scene` (traced natively) or a callable with `channels` outputs;
/// `request` is the core's `MapRequest` as a dict of its fields.
#[pyfunction]
#[pyo3(signature = (source, channels, request))]
pub fn generate<'py>(
    py: Python<'py>,
    source: Bound<'py, PyAny>,
    channels: usize,
    request: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let map = map_request(request)?;
    if let Ok(scene) = source.cast::<Scene>() {
        return run(py, &map, &scene.borrow().inner);
    }
    let callable = CallableSource {
        f: source.unbind(),
        channels,
        error: Mutex::new(None),
    };
    let r = run(py, &map, &callable);
    // The callable's own exception, not its message wrapped.
    if let Some(e) = callable
        .error
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .take()
    {
        return Err(e);
    }
    r
}

/// A dict of the core's `MapRequest` fields, checked by the core.
pub(crate) fn map_request(
    request: &Bound<'_, PyAny>,
) -> PyResult<spheremap::trace::generate::ResolvedMap> {
    let r: spheremap::trace::generate::MapRequest = super::request_of(request)?;
    r.resolve().map_err(to_py)
}
