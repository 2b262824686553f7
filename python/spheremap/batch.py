"""Batch runs (``spheremap batch``) from Python: one recipe over a library of maps, on local
threads or one task per input on a Dask cluster, with the manifest that makes reruns resume.

The planning, the work on each input and the manifest are the core's (the CLI runs the same);
this module only hands tasks to Dask and collects their records.
"""

from __future__ import annotations

import json
import os
import sys
import time
import uuid
from collections.abc import Iterable, Iterator, Mapping
from typing import Any

from . import _spheremap as _ext

__all__ = ["Manifest", "run"]


class Manifest:
    """``DIR/manifest.jsonl`` as read after a run: one record (a dict) per input — ``input``,
    ``input_hash``, ``recipe_hash``, ``outputs`` (each ``path`` relative to DIR and ``hash``),
    ``seconds``, ``worker``, ``error`` (None when it succeeded) — and the run's ``summary``
    (inputs, done, skipped, failed, cancelled, outputs, seconds, files_per_second, workers)."""

    def __init__(self, out_dir: str, records: list[dict[str, Any]], summary: dict[str, Any]) -> None:
        self.out_dir = out_dir
        self.path = os.path.join(out_dir, "manifest.jsonl")
        self.records = records
        self.summary = summary

    @classmethod
    def read(cls, out_dir: str | os.PathLike[str]) -> Manifest:
        """The manifest of an output folder (the last record of each input)."""
        d = os.fspath(out_dir)
        return cls(d, _ext._batch_read_manifest(d), {})

    @property
    def failed(self) -> list[dict[str, Any]]:
        return [r for r in self.records if r.get("error")]

    @property
    def done(self) -> list[dict[str, Any]]:
        return [r for r in self.records if not r.get("error")]

    def __iter__(self) -> Iterator[dict[str, Any]]:
        return iter(self.records)

    def __len__(self) -> int:
        return len(self.records)

    def __repr__(self) -> str:
        return f"<spheremap.batch.Manifest {self.path}: {len(self.done)} done, {len(self.failed)} failed>"


def _dask_task(task: dict[str, Any], recipe: dict[str, Any], out_dir: str) -> dict[str, Any]:
    """One input on a Dask worker (spheremap installed there; the output folder shared)."""
    try:
        from distributed import get_worker

        worker = get_worker().address
    except (ImportError, ValueError):
        worker = "dask"
    return _ext._batch_run_task(task=task, recipe=recipe, out_dir=out_dir, worker=worker)


def run(
    inputs: str | os.PathLike[str] | Iterable[str | os.PathLike[str]],
    recipe: str | os.PathLike[str] | Mapping[str, Any],
    out_dir: str | os.PathLike[str],
    *,
    client: Any = None,
    workers: int | None = None,
    force: bool = False,
    progress: bool = False,
) -> Manifest:
    """Makes every output of `recipe` from every input into `out_dir` (``spheremap batch``).

    inputs: files, folders (the image files directly in them) or glob patterns.
    recipe: a TOML file, or the same as a dict (``{"output": [{"op": "convert", "name": ...}]}``).
    client: a ``dask.distributed.Client``: one task per input on its cluster (the workers must
        have spheremap and see `out_dir`); a task whose worker dies is retried elsewhere.
        None: local threads (`workers`, default all cores).
    force: redo inputs the manifest records as done. progress: a progress line on stderr.

    A bad input fails alone: its error is in its record (``Manifest.failed``). The recipe and
    the inputs are checked before any work (ValueError, FileNotFoundError naming them).
    """
    if client is not None and workers is not None:
        raise ValueError("workers: give workers or client, not both (a Dask cluster has its own)")
    recipe = _ext._batch_recipe(recipe=recipe)  # checked, and as a dict the workers take
    plan = _ext._batch_plan(inputs=inputs, recipe=recipe, out_dir=out_dir, force=bool(force))
    out = os.fspath(out_dir)
    if client is None:
        got = _ext._batch_run_local(plan=plan, recipe=recipe, workers=workers)
        if got["summary"]["cancelled"]:
            # Ctrl-C: the inputs in progress finished and were recorded; a rerun resumes.
            raise KeyboardInterrupt
        return Manifest(out, _records_of(out, plan), got["summary"])
    return _run_dask(plan, recipe, out, client, progress)


def _records_of(out: str, plan: dict[str, Any]) -> list[dict[str, Any]]:
    """The manifest's records of the plan's inputs, in the plan's order."""
    by_input = {r["input"]: r for r in _ext._batch_read_manifest(out)}
    return [by_input[t["input"]] for t in plan["tasks"] if t["input"] in by_input]


def _run_dask(plan, recipe, out, client, progress) -> Manifest:
    from distributed import as_completed

    t0 = time.perf_counter()
    _ext._batch_prepare(out)
    out_abs = os.path.abspath(out)
    todo = [t for t, skip in zip(plan["tasks"], plan["skip"]) if not skip]
    run_id = uuid.uuid4().hex[:8]
    futures = {
        client.submit(_dask_task, t, recipe, out_abs, key=f"spheremap-batch-{run_id}-{t['index']}", pure=False,
                      retries=2): t
        for t in todo
    }
    bar = _ext.BatchProgress(len(plan["tasks"]), len(plan["tasks"]) - len(todo), bool(progress))
    results: dict[int, dict[str, Any] | None] = {t["index"]: None for t in todo}
    try:
        for fut in as_completed(list(futures)):
            t = futures[fut]
            try:
                rec = fut.result()
            except Exception as e:  # the task itself failed on every try (a worker kept dying)
                first = str(e).splitlines()[0] if str(e) else type(e).__name__
                error = f"{t['input']}: the Dask task failed: {first}"
                rec = _ext._batch_failed_record(t, plan["recipe_hash"], error)
            # Records use the task's own paths relative to the caller, as the local runner does.
            for o in rec["outputs"]:
                if os.path.isabs(o["path"]):
                    o["path"] = os.path.relpath(o["path"], out_abs)
            _ext._batch_append(out, rec)
            results[t["index"]] = rec
            bar.record(rec)
    except KeyboardInterrupt:
        client.cancel(list(futures))
        bar.close()
        raise
    bar.close()
    n_workers = len(client.scheduler_info().get("workers", {}))
    summary = _ext._batch_summary(plan, list(results.values()), time.perf_counter() - t0, n_workers)
    return Manifest(out, _records_of(out, plan), summary)


def _client_for(address: str):
    """A Dask client for a scheduler address, or a LocalCluster for local:N."""
    try:
        from distributed import Client, LocalCluster
    except ImportError as e:
        raise RuntimeError(f"--dask: needs the dask extra (pip install 'spheremap[dask]'): {e}") from None
    if address.startswith("local:"):
        count = address.split(":", 1)[1]
        if not count.isdigit() or int(count) < 1:
            raise ValueError(f"--dask: local:N needs a worker count N >= 1, got {address!r}")
        n = int(count)
        # One task at a time per worker process; its kernels share the cores among workers.
        threads = max(1, (os.cpu_count() or 1) // n)
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            env={"RAYON_NUM_THREADS": str(threads)},
        )
        return Client(cluster), cluster
    return Client(address), None


def _main(argv: list[str]) -> int:
    """``python -m spheremap._dask_cli --spec JSON``: what ``spheremap batch --dask`` runs."""
    if len(argv) != 2 or argv[0] != "--spec":
        print("usage: python -m spheremap._dask_cli --spec JSON (run by spheremap batch --dask)", file=sys.stderr)
        return 2
    spec = json.loads(argv[1])
    try:
        client, cluster = _client_for(spec["dask"])
    except (RuntimeError, ValueError, OSError) as e:
        print(f"spheremap: {e}", file=sys.stderr)
        return 2
    try:
        m = run(spec["inputs"], spec["recipe"], spec["out"], client=client, force=spec["force"],
                progress=not spec["quiet"])
    except KeyboardInterrupt:
        print("spheremap: interrupted; rerun to resume", file=sys.stderr)
        return 130
    except (ValueError, OSError, TypeError) as e:
        print(f"spheremap: {str(e).splitlines()[0]}", file=sys.stderr)
        return 2
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    line, failed = _ext._batch_report(summary=m.summary, out_dir=spec["out"])
    if spec["json"]:
        print(json.dumps(m.summary))
    elif not spec["quiet"]:
        print(line, file=sys.stderr)
    if failed:
        print(f"spheremap: {failed}", file=sys.stderr)
    return 1 if failed else 0
