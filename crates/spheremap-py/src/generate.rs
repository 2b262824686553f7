//! PyO3 glue for the ray-traced generator: the `Scene` class and `generate` with a scene or a
//! Python callable as `fire_ray`.  No maths here.

use super::args::{image_out, rows_f32, vec3, FArr};
use super::{run_cancellable, to_py};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
use spheremap::jobs::scene::SceneRequest;
use spheremap::resample::Progress;
use spheremap::trace::generate::RaySource;
use spheremap::trace::scene::{self, Environment, Light};
use std::sync::Mutex;

/// A ray-traced scene (see the README): callable as `fire_ray(origins, directions)`.
#[pyclass(module = "spheremap._spheremap", name = "Scene")]
pub struct Scene {
    inner: scene::Scene,
}

impl Scene {
    /// The core scene (for the other glue modules).
    pub(crate) fn inner(&self) -> &scene::Scene {
        &self.inner
    }
}

#[pymethods]
impl Scene {
    /// The scene a `SceneRequest` (as a dict of its fields) names, lit as it says, with
    /// `environment` (an array in the request's `src` mapping; a cube map as faces, their stack
    /// or one image in a layout) as what rays leaving it see.
    #[staticmethod]
    #[pyo3(signature = (request, environment=None))]
    fn from_request(
        py: Python<'_>,
        request: &Bound<'_, PyAny>,
        environment: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Scene> {
        let req: SceneRequest = super::request_of(request)?;
        let env = environment
            .filter(|e| !e.is_none())
            .map(|e| {
                let img = super::source_arg(e, &req.source, req.nonfinite, "environment")?;
                req.env_of(img, "environment").map_err(to_py)
            })
            .transpose()?;
        let scene = py.detach(|| req.build(env.as_ref()));
        crate::emit_warnings(py)?;
        let inner = scene.map_err(to_py)?.ok_or_else(|| {
            PyValueError::new_err("scene: a Scene needs a scene file or a built-in scene")
        })?;
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

    fn set_background(&mut self, colour: &Bound<'_, PyAny>) -> PyResult<()> {
        self.inner.environment = Environment::Constant(vec3(colour, "background")?);
        Ok(())
    }

    /// An environment map (H, W, C) (a cube map as faces, their stack or one image in a
    /// layout) read as `request` says (an `EnvRequest` as a dict: `src`, `src_preset`,
    /// `src_layout`, `src_look`, `src_up`).
    #[pyo3(signature = (image, request))]
    fn set_environment(
        &mut self,
        image: &Bound<'_, PyAny>,
        request: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let req: SceneRequest = super::request_of(request)?;
        let img = super::source_arg(image, &req.source, req.nonfinite, "environment")?;
        let e = req.env_of(img, "environment").map_err(to_py)?;
        self.inner.environment = Environment::Map {
            image: e.image,
            mapping: e.mapping,
            rotation: e.rotation,
        };
        Ok(())
    }

    fn add_point_light(
        &mut self,
        position: &Bound<'_, PyAny>,
        intensity: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        self.inner.lights.push(Light::Point {
            position: vec3(position, "position")?,
            intensity: vec3(intensity, "intensity")?,
        });
        Ok(())
    }

    fn add_directional_light(
        &mut self,
        direction: &Bound<'_, PyAny>,
        irradiance: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let d = vec3(direction, "direction")?;
        if d == [0.0; 3] {
            return Err(PyValueError::new_err("direction: must not be zero"));
        }
        self.inner.lights.push(Light::Directional {
            direction: d,
            irradiance: vec3(irradiance, "irradiance")?,
        });
        Ok(())
    }

    /// Radiance along rays: origins, directions (K, 3) float32 -> (K, 3) float32, in parallel.
    fn trace<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (o, d) = rays(origins, directions)?;
        let (o, d): RayPair<'_> = (bytemuck::cast_slice(&o), bytemuck::cast_slice(&d));
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
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (o, d) = rays(origins, directions)?;
        let (o, d): RayPair<'_> = (bytemuck::cast_slice(&o), bytemuck::cast_slice(&d));
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

/// Origins and directions as 3-vectors.
type RayPair<'a> = (&'a [[f32; 3]], &'a [[f32; 3]]);

/// (K, 3) origins and directions, as many of each, as float32.
fn rays(o: &Bound<'_, PyAny>, d: &Bound<'_, PyAny>) -> PyResult<(Vec<f32>, Vec<f32>)> {
    let (o, d) = (rows_f32(o, "origins", 3)?, rows_f32(d, "directions", 3)?);
    if o.len() != d.len() {
        return Err(PyValueError::new_err(format!(
            "origins: {} rays but directions has {}",
            o.len() / 3,
            d.len() / 3
        )));
    }
    Ok((o, d))
}

/// What a `fire_ray` callable returned for `k` rays, as (K, C) float32 values with C in 1..4
/// (a (K,) result is one channel): (values, C).
fn colours(res: &Bound<'_, PyAny>, k: usize) -> PyResult<(Vec<f32>, usize)> {
    let a = FArr::extract(res, "fire_ray")?;
    let shape = a.shape();
    let c = match shape.as_slice() {
        [n] if *n == k => 1,
        [n, c] if *n == k && (1..=4).contains(c) => *c,
        _ => {
            return Err(PyValueError::new_err(format!(
                "fire_ray: returned shape {} for {k} rays; expected (K,) or (K, C) with C in 1..4",
                super::args::shape_text(&shape)
            )))
        }
    };
    Ok((a.to_f32(), c))
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
            let (v, c) = colours(res.bind(py), k)?;
            if c != self.channels {
                return Err(PyValueError::new_err(format!(
                    "fire_ray: returned {c} channels; the first call returned {}",
                    self.channels
                )));
            }
            out.copy_from_slice(&v);
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
    image_out(py, img, map.mapping.name() == "cube")
}

/// Generates with `source`: a `Scene` (traced natively) or a callable `fire_ray(origins,
/// directions)`, called first with one ray from `pos` to learn its channels; `request` is the
/// core's `MapRequest` as a dict of its fields.  A cube map comes back as its faces.
#[pyfunction]
#[pyo3(signature = (source, request))]
pub fn generate<'py>(
    py: Python<'py>,
    source: Bound<'py, PyAny>,
    request: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let req: spheremap::trace::generate::MapRequest = super::request_of(request)?;
    let map = req.resolve().map_err(to_py)?;
    if let Ok(scene) = source.cast::<Scene>() {
        return run(py, &map, &scene.borrow().inner);
    }
    if !source.is_callable() {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "fire_ray: expected a spheremap.Scene or a callable, got {}",
            source.get_type().name()?
        )));
    }
    let o = PyArray1::from_slice(py, &req.pos).reshape([1, 3])?;
    let d = PyArray1::from_slice(py, &[0f32, 0.0, 1.0]).reshape([1, 3])?;
    let (_, channels) = colours(&source.call1((o, d))?, 1)?;
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
