//! `spheremap batch`: a recipe over a library of maps (core: `spheremap::batch`), on local
//! threads or, with `--dask`, through the Python package on a Dask cluster.

use crate::progress::INTERRUPTED;
use anyhow::Context;
use spheremap::batch::{self, Manifest, Recipe, Record};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Input maps: files, folders (the image files directly in them) or glob patterns
    /// ('hdris/*.exr', quoted so the shell leaves it alone).
    #[arg(required = true)]
    inputs: Vec<String>,
    /// The recipe (TOML): one [[output]] table per file to make from each input; see
    /// docs/batch.md.
    #[arg(long)]
    recipe: String,
    /// The output folder (made if missing); DIR/manifest.jsonl records every input.
    #[arg(long)]
    out: String,
    /// Local threads (default: all cores).
    #[arg(long)]
    workers: Option<usize>,
    /// Run one task per input on a Dask cluster: a scheduler address (tcp://host:8786) or
    /// local:N for a LocalCluster of N worker processes. Needs Python with
    /// `pip install spheremap[dask]` ($SPHEREMAP_PYTHON, else python3).
    #[arg(long, conflicts_with = "workers")]
    dask: Option<String>,
    /// Redo every input, even those the manifest records as done.
    #[arg(long)]
    force: bool,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    json: bool,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let recipe = Recipe::read(Path::new(&a.recipe))?;
    if let Some(address) = &a.dask {
        return run_dask(&a, address);
    }
    if a.workers == Some(0) {
        anyhow::bail!("--workers: must be at least 1");
    }
    let out = Path::new(&a.out);
    let plan = batch::plan(&a.inputs, &recipe, out, a.force)?;
    let total = plan.tasks.len() as u64;
    let skipped = plan.skip.iter().filter(|s| **s).count() as u64;
    let bar = Progress::new(total, skipped, !a.quiet);
    let on_record = |r: &Record| bar.record(r);
    let cancel = AtomicBool::new(false);
    let summary = std::thread::scope(|s| {
        let work = s.spawn(|| {
            batch::run_local(&plan, &recipe, a.workers.unwrap_or(0), &cancel, &on_record)
        });
        while !work.is_finished() {
            std::thread::sleep(Duration::from_millis(20));
            if INTERRUPTED.load(Ordering::Relaxed) && !cancel.swap(true, Ordering::Relaxed) {
                bar.say("spheremap: interrupted: finishing the inputs in progress");
            }
        }
        work.join()
            .unwrap_or_else(|_| Err(spheremap::Error::param("batch", "a worker panicked")))
    })?;
    bar.finish();
    report(
        &a,
        &serde_json::to_value(&summary)?,
        summary.failed,
        summary.cancelled,
    )
}

/// The summary (stderr, or JSON on stdout) and the exit: 1 when an input failed, 130 when the
/// run was interrupted.
fn report(
    a: &Args,
    summary: &serde_json::Value,
    failed: usize,
    cancelled: usize,
) -> anyhow::Result<()> {
    if a.json {
        crate::out(&format!("{summary}\n"));
    } else if !a.quiet {
        eprintln!("{}", summary_line(summary));
    }
    if cancelled > 0 {
        std::process::exit(130);
    }
    if failed > 0 {
        return Err(crate::FoundProblem(failed_line(failed, Path::new(&a.out))).into());
    }
    Ok(())
}

/// The closing line of a run: its summary (the JSON summary's fields).
pub fn summary_line(summary: &serde_json::Value) -> String {
    let g = |k: &str| summary[k].as_u64().unwrap_or(0);
    let cancelled = g("cancelled");
    format!(
        "{} inputs: {} done, {} skipped, {} failed{} in {:.1} s ({:.2} files/s) on {} workers; \
         manifest {}",
        g("inputs"),
        g("done"),
        g("skipped"),
        g("failed"),
        if cancelled > 0 {
            format!(", {cancelled} not started (interrupted)")
        } else {
            String::new()
        },
        summary["seconds"].as_f64().unwrap_or(0.0),
        summary["files_per_second"].as_f64().unwrap_or(0.0),
        g("workers"),
        summary["manifest"].as_str().unwrap_or(""),
    )
}

/// The error a run ends with when `failed` inputs failed.
pub fn failed_line(failed: usize, out_dir: &Path) -> String {
    format!(
        "{failed} input{} failed (see {})",
        if failed == 1 { "" } else { "s" },
        Manifest::path(out_dir).display()
    )
}

/// A batch run's progress line on stderr (inputs done, skipped and failed, files per second,
/// time left), each failed input's error printed above it; nothing when not shown.
pub struct Progress {
    bar: Option<indicatif::ProgressBar>,
    skipped: u64,
    failed: AtomicUsize,
}

impl Progress {
    /// For `total` inputs of which `skipped` are done already.
    pub fn new(total: u64, skipped: u64, show: bool) -> Progress {
        let bar = show.then(|| {
            use indicatif::{ProgressBar, ProgressStyle};
            let b = ProgressBar::new(total);
            b.set_style(
                ProgressStyle::with_template(
                    "{spinner} [{bar:30}] {pos}/{len} inputs ({msg}), {per_sec}, {eta} left",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            b.set_position(skipped);
            b.set_message(format!("{skipped} skipped, 0 failed"));
            b.enable_steady_tick(Duration::from_millis(200));
            b
        });
        Progress {
            bar,
            skipped,
            failed: AtomicUsize::new(0),
        }
    }

    /// One input finished (its error, if any, is printed).
    pub fn record(&self, r: &Record) {
        if let Some(e) = &r.error {
            self.failed.fetch_add(1, Ordering::Relaxed);
            self.say(&format!("spheremap: {e}"));
        }
        if let Some(b) = &self.bar {
            b.inc(1);
            b.set_message(format!(
                "{} skipped, {} failed",
                self.skipped,
                self.failed.load(Ordering::Relaxed)
            ));
        }
    }

    /// A line on stderr above the bar.
    pub fn say(&self, line: &str) {
        // (suspend, not println: a hidden bar, stderr not a terminal, prints nothing)
        match &self.bar {
            Some(b) => b.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        }
    }

    /// Clears the bar.
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// `--dask`: the Python package runs the batch (`python -m spheremap._dask_cli --spec JSON`), with
/// the same planning, tasks and manifest from this crate's core.
fn run_dask(a: &Args, address: &str) -> anyhow::Result<()> {
    let python = std::env::var("SPHEREMAP_PYTHON").unwrap_or_else(|_| "python3".into());
    let spec = serde_json::json!({
        "inputs": a.inputs,
        "recipe": a.recipe,
        "out": a.out,
        "dask": address,
        "force": a.force,
        "json": a.json,
        "quiet": a.quiet,
    });
    let status = std::process::Command::new(&python)
        .args(["-m", "spheremap._dask_cli", "--spec"])
        .arg(spec.to_string())
        .status()
        .with_context(|| format!("--dask: cannot run {python} (set SPHEREMAP_PYTHON)"))?;
    // The Python side printed its own errors and summary: pass its exit status on.
    match status.code() {
        Some(0) => Ok(()),
        Some(c) => std::process::exit(c),
        None => std::process::exit(130),
    }
}
