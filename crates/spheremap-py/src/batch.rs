//! `spheremap.batch`: the core's batch engine for Python (translation only). Plans, tasks,
//! records and summaries cross as Python dicts and lists of the core's serde types, which the
//! Dask path ships between processes as they are.

use crate::to_py;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use spheremap::batch::{self, Manifest, Plan, Recipe, Task};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// A recipe from its text: TOML, or JSON when `is_json` (a dict passed from Python); `source`
/// names it in errors.
fn recipe(text: &str, is_json: bool, source: &str) -> PyResult<Recipe> {
    if is_json {
        Recipe::parse_json(text, source)
    } else {
        Recipe::parse(text, source)
    }
    .map_err(to_py)
}

/// A core value as Python data (dicts, lists, strings, numbers).
fn to_python<'py, T: serde::Serialize>(
    py: Python<'py>,
    what: &str,
    v: &T,
) -> PyResult<Bound<'py, PyAny>> {
    pythonize::pythonize(py, v).map_err(|e| PyValueError::new_err(format!("{what}: {e}")))
}

/// Python data as a core value; the error names `what`.
fn of_python<T: serde::de::DeserializeOwned>(what: &str, v: &Bound<'_, PyAny>) -> PyResult<T> {
    pythonize::depythonize(v).map_err(|e| PyValueError::new_err(format!("{what}: {e}")))
}

/// Validates a recipe; returns its hash.
#[pyfunction]
#[pyo3(signature = (text, is_json, source))]
pub fn _batch_recipe(text: &str, is_json: bool, source: &str) -> PyResult<String> {
    Ok(recipe(text, is_json, source)?.hash)
}

/// The plan of a batch.
#[pyfunction]
#[pyo3(signature = (inputs, text, is_json, source, out_dir, force))]
pub fn _batch_plan<'py>(
    py: Python<'py>,
    inputs: Vec<String>,
    text: &str,
    is_json: bool,
    source: &str,
    out_dir: &str,
    force: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let r = recipe(text, is_json, source)?;
    let plan = py
        .detach(|| batch::plan(&inputs, &r, Path::new(out_dir), force))
        .map_err(to_py)?;
    to_python(py, "plan", &plan)
}

/// Makes the output folder and compacts its manifest (before tasks are handed out).
#[pyfunction]
pub fn _batch_prepare(out_dir: &str) -> PyResult<()> {
    let d = Path::new(out_dir);
    std::fs::create_dir_all(d).map_err(|e| to_py(spheremap::Error::io(d, e)))?;
    Manifest::compact(d).map_err(to_py)
}

/// Runs one task and returns its record; never raises for the input's own errors, which are
/// in the record.
#[pyfunction]
#[pyo3(signature = (task, text, is_json, source, out_dir, worker))]
pub fn _batch_run_task<'py>(
    py: Python<'py>,
    task: &Bound<'py, PyAny>,
    text: &str,
    is_json: bool,
    source: &str,
    out_dir: &str,
    worker: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let r = recipe(text, is_json, source)?;
    let t: Task = of_python("task", task)?;
    let rec = py.detach(|| batch::run_task(&t, &r, Path::new(out_dir), worker, None));
    to_python(py, "record", &rec)
}

/// The record of a task that never ran to its end (its Dask task failed on every try): the
/// input failed with `error`.
#[pyfunction]
#[pyo3(signature = (task, recipe_hash, error))]
pub fn _batch_failed_record<'py>(
    py: Python<'py>,
    task: &Bound<'py, PyAny>,
    recipe_hash: &str,
    error: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let t: Task = of_python("task", task)?;
    to_python(
        py,
        "record",
        &batch::Record::failed(&t.input, recipe_hash, "dask", error),
    )
}

/// Appends a record to the manifest.
#[pyfunction]
pub fn _batch_append(out_dir: &str, record: &Bound<'_, PyAny>) -> PyResult<()> {
    let r: batch::Record = of_python("record", record)?;
    Manifest::append(Path::new(out_dir), &r).map_err(to_py)
}

/// Runs a plan on local threads; Ctrl-C stops starting inputs. Returns the summary and the
/// records made (`{"summary": …, "records": […]}`).
#[pyfunction]
#[pyo3(signature = (plan, text, is_json, source, workers))]
pub fn _batch_run_local<'py>(
    py: Python<'py>,
    plan: &Bound<'py, PyAny>,
    text: &str,
    is_json: bool,
    source: &str,
    workers: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let r = recipe(text, is_json, source)?;
    let p: Plan = of_python("plan", plan)?;
    let cancel = AtomicBool::new(false);
    let records = std::sync::Mutex::new(Vec::new());
    let on_record = |rec: &batch::Record| {
        if let Ok(mut v) = records.lock() {
            v.push(rec.clone());
        }
    };
    let summary = py.detach(|| {
        std::thread::scope(|s| {
            let work = s.spawn(|| batch::run_local(&p, &r, workers, &cancel, &on_record));
            while !work.is_finished() {
                std::thread::sleep(std::time::Duration::from_millis(20));
                if Python::attach(|py| py.check_signals()).is_err() {
                    cancel.store(true, Ordering::SeqCst);
                }
            }
            work.join()
                .unwrap_or_else(|_| Err(spheremap::Error::param("batch", "a worker panicked")))
        })
    });
    let summary = summary.map_err(to_py)?;
    let records = records.into_inner().unwrap_or_default();
    to_python(
        py,
        "summary",
        &serde_json::json!({"summary": summary, "records": records}),
    )
}

/// The summary of a run made elsewhere (Dask): `results` a list of records, or None for an
/// input not started.
#[pyfunction]
#[pyo3(signature = (plan, results, seconds, workers))]
pub fn _batch_summary<'py>(
    py: Python<'py>,
    plan: &Bound<'py, PyAny>,
    results: &Bound<'py, PyAny>,
    seconds: f64,
    workers: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let p: Plan = of_python("plan", plan)?;
    let r: Vec<Option<batch::Record>> = of_python("results", results)?;
    to_python(py, "summary", &batch::Summary::of(&p, &r, seconds, workers))
}

/// The manifest of `out_dir`: the last record of each input.
#[pyfunction]
pub fn _batch_read_manifest<'py>(py: Python<'py>, out_dir: &str) -> PyResult<Bound<'py, PyAny>> {
    let m = Manifest::read(Path::new(out_dir)).map_err(to_py)?;
    to_python(py, "manifest", &m.records.values().collect::<Vec<_>>())
}
