//! `spheremap.batch`: the core's batch engine for Python (translation only). Plans, tasks,
//! records and summaries cross as JSON text, so the Dask path ships them between processes as
//! they are.

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

fn json_err(what: &str) -> impl Fn(serde_json::Error) -> PyErr + '_ {
    move |e| PyValueError::new_err(format!("{what}: {e}"))
}

/// Validates a recipe; returns its hash.
#[pyfunction]
#[pyo3(signature = (text, is_json, source))]
pub fn _batch_recipe(text: &str, is_json: bool, source: &str) -> PyResult<String> {
    Ok(recipe(text, is_json, source)?.hash)
}

/// The plan of a batch, as JSON.
#[pyfunction]
#[pyo3(signature = (inputs, text, is_json, source, out_dir, force))]
pub fn _batch_plan(
    py: Python<'_>,
    inputs: Vec<String>,
    text: &str,
    is_json: bool,
    source: &str,
    out_dir: &str,
    force: bool,
) -> PyResult<String> {
    let r = recipe(text, is_json, source)?;
    let plan = py
        .detach(|| batch::plan(&inputs, &r, Path::new(out_dir), force))
        .map_err(to_py)?;
    serde_json::to_string(&plan).map_err(json_err("plan"))
}

/// Makes the output folder and compacts its manifest (before tasks are handed out).
#[pyfunction]
pub fn _batch_prepare(out_dir: &str) -> PyResult<()> {
    let d = Path::new(out_dir);
    std::fs::create_dir_all(d).map_err(|e| to_py(spheremap::Error::io(d, e)))?;
    Manifest::compact(d).map_err(to_py)
}

/// Runs one task (JSON) and returns its record (JSON); never raises for the input's own
/// errors, which are in the record.
#[pyfunction]
#[pyo3(signature = (task, text, is_json, source, out_dir, worker))]
pub fn _batch_run_task(
    py: Python<'_>,
    task: &str,
    text: &str,
    is_json: bool,
    source: &str,
    out_dir: &str,
    worker: &str,
) -> PyResult<String> {
    let r = recipe(text, is_json, source)?;
    let t: Task = serde_json::from_str(task).map_err(json_err("task"))?;
    let rec = py.detach(|| batch::run_task(&t, &r, Path::new(out_dir), worker, None));
    serde_json::to_string(&rec).map_err(json_err("record"))
}

/// Appends a record (JSON) to the manifest.
#[pyfunction]
pub fn _batch_append(out_dir: &str, record: &str) -> PyResult<()> {
    let r: batch::Record = serde_json::from_str(record).map_err(json_err("record"))?;
    Manifest::append(Path::new(out_dir), &r).map_err(to_py)
}

/// Runs a plan (JSON) on local threads; Ctrl-C stops starting inputs. Returns the summary and
/// the records made, as JSON.
#[pyfunction]
#[pyo3(signature = (plan, text, is_json, source, workers))]
pub fn _batch_run_local(
    py: Python<'_>,
    plan: &str,
    text: &str,
    is_json: bool,
    source: &str,
    workers: usize,
) -> PyResult<String> {
    let r = recipe(text, is_json, source)?;
    let p: Plan = serde_json::from_str(plan).map_err(json_err("plan"))?;
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
    serde_json::to_string(&serde_json::json!({"summary": summary, "records": records}))
        .map_err(json_err("summary"))
}

/// The summary of a run made elsewhere (Dask): `results` a JSON list of records or null (not
/// started).
#[pyfunction]
#[pyo3(signature = (plan, results, seconds, workers))]
pub fn _batch_summary(plan: &str, results: &str, seconds: f64, workers: usize) -> PyResult<String> {
    let p: Plan = serde_json::from_str(plan).map_err(json_err("plan"))?;
    let r: Vec<Option<batch::Record>> =
        serde_json::from_str(results).map_err(json_err("results"))?;
    serde_json::to_string(&batch::Summary::of(&p, &r, seconds, workers))
        .map_err(json_err("summary"))
}

/// The manifest of `out_dir`: the last record of each input, as a JSON list.
#[pyfunction]
pub fn _batch_read_manifest(out_dir: &str) -> PyResult<String> {
    let m = Manifest::read(Path::new(out_dir)).map_err(to_py)?;
    serde_json::to_string(&m.records.values().collect::<Vec<_>>()).map_err(json_err("manifest"))
}
