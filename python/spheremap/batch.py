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


def _recipe_arg(recipe: Any) -> tuple[str, bool, str]:
    """(text, is_json, source) of a recipe given as a path or as a mapping."""
    if isinstance(recipe, Mapping):
        return json.dumps(recipe), True, "recipe"
    if isinstance(recipe, (str, os.PathLike)):
        path = os.fspath(recipe)
        try:
            with open(path, "rb") as f:
                raw = f.read()
        except FileNotFoundError:
            raise FileNotFoundError(f"recipe: {path}: no such file") from None
        try:
            return raw.decode("utf-8"), False, path
        except UnicodeDecodeError:
            raise ValueError(f"recipe: {path}: the recipe is not UTF-8 text") from None
    raise TypeError(f"recipe: expected a path or a dict, got {type(recipe).__name__}")


def _inputs_arg(inputs: Any) -> list[str]:
    if isinstance(inputs, (str, os.PathLike)):
        return [os.fspath(inputs)]
    if isinstance(inputs, Iterable):
        out = []
        for i in inputs:
            if not isinstance(i, (str, os.PathLike)):
                raise TypeError(f"inputs: expected paths, got {type(i).__name__}")
            out.append(os.fspath(i))
        return out
    raise TypeError(f"inputs: expected a path or a list of paths, got {type(inputs).__name__}")


class _Progress:
    """A one-line progress report on stderr: inputs done / failed, throughput, ETA."""

    def __init__(self, total: int, skipped: int, show: bool) -> None:
        self.total, self.done, self.failed, self.show = total, skipped, 0, show
        self.start = time.perf_counter()
        self.new = 0

    def record(self, rec: dict[str, Any]) -> None:
        self.done += 1
        self.new += 1
        if rec.get("error"):
            self.failed += 1
            if self.show:
                sys.stderr.write("\r\033[K")
            print(f"spheremap: {rec['error']}", file=sys.stderr)
        if self.show:
            dt = time.perf_counter() - self.start
            rate = self.new / dt if dt > 0 else 0.0
            eta = (self.total - self.done) / rate if rate > 0 else float("nan")
            sys.stderr.write(
                f"\r\033[K{self.done}/{self.total} inputs ({self.failed} failed), {rate:.2f} files/s, "
                f"{eta:.0f} s left"
            )
            sys.stderr.flush()

    def close(self) -> None:
        if self.show:
            sys.stderr.write("\r\033[K")
            sys.stderr.flush()


def _dask_task(task: dict[str, Any], text: str, is_json: bool, source: str, out_dir: str) -> dict[str, Any]:
    """One input on a Dask worker (spheremap installed there; the output folder shared)."""
    try:
        from distributed import get_worker

        worker = get_worker().address
    except (ImportError, ValueError):
        worker = "dask"
    return _ext._batch_run_task(task, text, is_json, source, out_dir, worker)


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
    names = _inputs_arg(inputs)
    text, is_json, source = _recipe_arg(recipe)
    if not isinstance(out_dir, (str, os.PathLike)):
        raise TypeError(f"out_dir: expected a path, got {type(out_dir).__name__}")
    out = os.fspath(out_dir)
    if workers is not None and (not isinstance(workers, int) or isinstance(workers, bool) or workers < 1):
        raise ValueError(f"workers: expected a positive integer, got {workers!r}")
    if client is not None and workers is not None:
        raise ValueError("workers: give workers or client, not both (a Dask cluster has its own)")
    plan = _ext._batch_plan(names, text, is_json, source, out, bool(force))
    if client is None:
        got = _ext._batch_run_local(plan, text, is_json, source, workers or 0)
        if got["summary"]["cancelled"]:
            # Ctrl-C: the inputs in progress finished and were recorded; a rerun resumes.
            raise KeyboardInterrupt
        return Manifest(out, _records_of(out, plan), got["summary"])
    return _run_dask(plan, text, is_json, source, out, client, progress)


def _records_of(out: str, plan: dict[str, Any]) -> list[dict[str, Any]]:
    """The manifest's records of the plan's inputs, in the plan's order."""
    by_input = {r["input"]: r for r in _ext._batch_read_manifest(out)}
    return [by_input[t["input"]] for t in plan["tasks"] if t["input"] in by_input]


def _run_dask(plan, text, is_json, source, out, client, progress) -> Manifest:
    from distributed import as_completed

    t0 = time.perf_counter()
    _ext._batch_prepare(out)
    out_abs = os.path.abspath(out)
    todo = [t for t, skip in zip(plan["tasks"], plan["skip"]) if not skip]
    run_id = uuid.uuid4().hex[:8]
    futures = {
        client.submit(
            _dask_task,
            t,
            text,
            is_json,
            source,
            out_abs,
            key=f"spheremap-batch-{run_id}-{t['index']}",
            pure=False,
            retries=2,
        ): t
        for t in todo
    }
    bar = _Progress(len(plan["tasks"]), len(plan["tasks"]) - len(todo), progress)
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
    s = m.summary
    if spec["json"]:
        print(json.dumps(s))
    elif not spec["quiet"]:
        print(
            f"{s['inputs']} inputs: {s['done']} done, {s['skipped']} skipped, {s['failed']} failed in "
            f"{s['seconds']:.1f} s ({s['files_per_second']:.2f} files/s) on {s['workers']} Dask workers; "
            f"manifest {s['manifest']}",
            file=sys.stderr,
        )
    if s["failed"]:
        print(f"spheremap: {s['failed']} input(s) failed (see {s['manifest']})", file=sys.stderr)
        return 1
    return 0
