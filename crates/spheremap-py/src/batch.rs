//! `spheremap.batch`: the core's batch engine for Python (translation only). Plans, tasks,
//! records and summaries cross as Python dicts and lists of the core's serde types, which the
//! Dask path ships between processes as they are.

use crate::to_py;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spheremap::batch::{self, Manifest, Plan, Recipe, Task};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// A recipe argument: a path to its TOML file, or the same recipe as a dict (`{"output":
/// [{…}, …]}`), validated by the core; errors name it (`recipe: …`).
fn recipe_arg(ob: &Bound<'_, PyAny>) -> PyResult<Recipe> {
    if let Ok(path) = ob.extract::<std::path::PathBuf>() {
        return Recipe::read(&path).map_err(|e| {
            let e = to_py(e);
            let py = ob.py();
            PyErr::from_type(e.get_type(py), format!("recipe: {}", e.value(py)))
        });
    }
    if ob.is_instance_of::<PyDict>() {
        return Recipe::from_json(&of_python("recipe", ob)?, "recipe").map_err(to_py);
    }
    Err(PyTypeError::new_err(format!(
        "recipe: expected a path or a dict, got {}",
        ob.get_type().name()?
    )))
}

/// An inputs argument: a path (a file, a folder or a glob pattern) or a list of them.
fn inputs_arg(ob: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    let path = |o: &Bound<'_, PyAny>| {
        o.extract::<std::path::PathBuf>()
            .map(|p| p.to_string_lossy().into_owned())
    };
    if let Ok(p) = path(ob) {
        return Ok(vec![p]);
    }
    let items = ob.try_iter().map_err(|_| {
        PyTypeError::new_err(format!(
            "inputs: expected a path or a list of paths, got {}",
            ob.get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_default()
        ))
    })?;
    items
        .map(|i| {
            let i = i?;
            path(&i).map_err(|_| {
                PyTypeError::new_err(format!(
                    "inputs: expected paths, got {}",
                    i.get_type()
                        .name()
                        .map(|n| n.to_string())
                        .unwrap_or_default()
                ))
            })
        })
        .collect()
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

/// Validates a recipe (a path or a dict) and returns it as a dict, what the other calls and
/// Dask's workers take.
#[pyfunction]
pub fn _batch_recipe<'py>(
    py: Python<'py>,
    recipe: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    to_python(py, "recipe", &recipe_arg(recipe)?.table)
}

/// The plan of a batch.
#[pyfunction]
#[pyo3(signature = (inputs, recipe, out_dir, force))]
pub fn _batch_plan<'py>(
    py: Python<'py>,
    inputs: &Bound<'py, PyAny>,
    recipe: &Bound<'py, PyAny>,
    out_dir: std::path::PathBuf,
    force: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let inputs = inputs_arg(inputs)?;
    let r = recipe_arg(recipe)?;
    let plan = py
        .detach(|| batch::plan(&inputs, &r, &out_dir, force))
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
#[pyo3(signature = (task, recipe, out_dir, worker))]
pub fn _batch_run_task<'py>(
    py: Python<'py>,
    task: &Bound<'py, PyAny>,
    recipe: &Bound<'py, PyAny>,
    out_dir: &str,
    worker: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let r = recipe_arg(recipe)?;
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

/// Runs a plan on local threads (`workers`, default all cores); Ctrl-C stops starting inputs.
/// Returns the summary and the records made (`{"summary": …, "records": […]}`).
#[pyfunction]
#[pyo3(signature = (plan, recipe, workers=None))]
pub fn _batch_run_local<'py>(
    py: Python<'py>,
    plan: &Bound<'py, PyAny>,
    recipe: &Bound<'py, PyAny>,
    workers: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let r = recipe_arg(recipe)?;
    let workers = workers
        .map(|w| crate::args::positive(w, "workers"))
        .transpose()?
        .unwrap_or(0);
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

/// The closing lines of a run made elsewhere (Dask), as the CLI prints its own: the summary,
/// and the error when inputs failed (None when none did).
#[pyfunction]
pub fn _batch_report(
    summary: &Bound<'_, PyAny>,
    out_dir: std::path::PathBuf,
) -> PyResult<(String, Option<String>)> {
    let s: serde_json::Value = of_python("summary", summary)?;
    let failed = s["failed"].as_u64().unwrap_or(0) as usize;
    Ok((
        spheremap_cli::cmd_batch::summary_line(&s),
        (failed > 0).then(|| spheremap_cli::cmd_batch::failed_line(failed, &out_dir)),
    ))
}

/// The progress line of a run made elsewhere (Dask), the CLI's own: `record(record)` for each
/// input finished, `close()` at the end.
#[pyclass(module = "spheremap._spheremap")]
pub struct BatchProgress {
    inner: spheremap_cli::cmd_batch::Progress,
}

#[pymethods]
impl BatchProgress {
    #[new]
    fn new(total: u64, skipped: u64, show: bool) -> Self {
        BatchProgress {
            inner: spheremap_cli::cmd_batch::Progress::new(total, skipped, show),
        }
    }

    fn record(&self, record: &Bound<'_, PyAny>) -> PyResult<()> {
        let r: batch::Record = of_python("record", record)?;
        self.inner.record(&r);
        Ok(())
    }

    fn close(&self) {
        self.inner.finish();
    }
}
