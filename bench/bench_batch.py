"""`spheremap batch` against the loops people write, on one library: 32 lat-long HDRIs
(2048x1024, float EXR, made from the bundled HDRIs turned by different angles) through the recipe
bench/batch.toml (a 512^2 sphere map EXR, a 256^2 PNG preview and a 2048x1024 lat-long each):

* `spheremap batch` on all cores (inputs in parallel, kernels sharing the threads), and with
  --workers 1 (one input at a time, its kernels on one thread);
* a shell loop calling `spheremap convert` once per output (each call's kernels on all cores);
* a Python loop over `spheremap.convert` (each input read once, kernels on all cores);
* `--dask local:2` (two worker processes) against --workers 1, and the Dask scheduler's
  overhead per task, from a recipe that does almost nothing on tiny inputs.

    python bench/bench_batch.py [--inputs 32] [--cli target/release/spheremap]

Goals (2 cores): batch >= 1.3x the faster loop; Dask local:2 >= 1.7x --workers 1.
"""

import argparse
import glob
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

import spheremap as sm

from machine import cpu_model

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
RECIPE = os.path.join(HERE, "batch.toml")
OUTPUTS = [  # the recipe's outputs as convert calls: (name pattern, to, size)
    ("{stem}_sphere.exr", "sphere", 512),
    ("{stem}_preview.png", "sphere", 256),
    ("{stem}_latlong.exr", "latlong", 1024),
]


def timed(f):
    t = time.perf_counter()
    f()
    return time.perf_counter() - t


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--inputs", type=int, default=32)
    ap.add_argument("--cli", help="the spheremap binary (default: the installed console script)")
    a = ap.parse_args()
    installed = shutil.which("spheremap")
    exe = [a.cli] if a.cli else ([installed] if installed else [sys.executable, "-m", "spheremap"])
    env = {**os.environ, "SPHEREMAP_PYTHON": sys.executable}
    sources = sorted(glob.glob(os.path.join(ROOT, "testdata/hdri/*.exr")))
    with tempfile.TemporaryDirectory() as tmp:
        lib = os.path.join(tmp, "lib")
        os.makedirs(lib)
        for i in range(a.inputs):
            src = sources[i % len(sources)]
            subprocess.run([*exe, "convert", src, os.path.join(lib, f"hdri{i:03d}.exr"), "--from", "latlong",
                            "--to", "latlong", "--size", "1024", "--yaw", str(37 * i), "-q"], check=True)
        n = a.inputs

        def batch(*extra, out):
            subprocess.run([*exe, "batch", lib, "--recipe", RECIPE, "--out", out, "-q", *extra], check=True, env=env)

        def shell_loop(out):
            os.makedirs(out)
            script = "set -e\nfor f in \"$1\"/*.exr; do s=$(basename \"$f\" .exr)\n" + "".join(
                f'  "$2" convert "$f" "$3/{p.replace("{stem}", "${s}")}" --to {to} --size {size} -q\n'
                for p, to, size in OUTPUTS
            ) + "done\n"
            subprocess.run(["bash", "-c", script, "loop", lib, " ".join(exe), out], check=True)

        def python_loop(out):
            os.makedirs(out)
            for f in sorted(glob.glob(os.path.join(lib, "*.exr"))):
                stem = os.path.splitext(os.path.basename(f))[0]
                img = sm.read_image(f)
                for p, to, size in OUTPUTS:
                    res = sm.convert(img, "latlong", to, size=size)
                    sm.write_image(os.path.join(out, p.replace("{stem}", stem)), res, mapping=to)

        rows = []
        t_batch = timed(lambda: batch(out=os.path.join(tmp, "b")))
        rows.append(("spheremap batch (all cores)", t_batch))
        t_w1 = timed(lambda: batch("--workers", "1", out=os.path.join(tmp, "b1")))
        rows.append(("spheremap batch --workers 1", t_w1))
        t_shell = timed(lambda: shell_loop(os.path.join(tmp, "sh")))
        rows.append(("shell loop of spheremap convert", t_shell))
        t_py = timed(lambda: python_loop(os.path.join(tmp, "py")))
        rows.append(("Python loop of spheremap.convert", t_py))
        t_dask = timed(lambda: batch("--dask", "local:2", out=os.path.join(tmp, "d2")))
        rows.append(("spheremap batch --dask local:2", t_dask))

        # The scheduler's overhead per task: tiny inputs, an SH9 each (microseconds of work).
        tiny = os.path.join(tmp, "tiny")
        os.makedirs(tiny)
        for i in range(n):
            sm.write_image(os.path.join(tiny, f"t{i:03d}.exr"), np.full((8, 16, 3), 1.0 + i, np.float32),
                           mapping="latlong")
        tiny_recipe = os.path.join(tmp, "tiny.toml")
        with open(tiny_recipe, "w") as f:
            f.write('[[output]]\nop = "irradiance"\nname = "{stem}.json"\n')

        from distributed import Client, LocalCluster

        threads = str(max(1, (os.cpu_count() or 1) // 2))
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                          env={"RAYON_NUM_THREADS": threads}) as cluster, Client(cluster) as client:
            t_warm = timed(lambda: sm.batch.run(lib, RECIPE, os.path.join(tmp, "dw"), client=client))
            rows.append(("spheremap.batch.run, Dask (2 workers started)", t_warm))
            t_tiny_dask = timed(lambda: sm.batch.run(tiny, tiny_recipe, os.path.join(tmp, "td"), client=client))
        t_tiny_local = timed(lambda: sm.batch.run(tiny, tiny_recipe, os.path.join(tmp, "tl"), workers=1))

    print(f"CPU: {cpu_model()} ({os.cpu_count()} cores); {n} lat-long HDRIs 2048x1024 -> bench/batch.toml")
    print(f"{'run':40s} {'seconds':>8s} {'files/s':>8s}")
    for name, t in rows:
        print(f"{name:40s} {t:8.1f} {n / t:8.2f}")
    faster_loop = min(t_shell, t_py)
    print(f"batch vs the faster loop: {faster_loop / t_batch:.2f}x (goal >= 1.3)")
    print(f"Dask local:2 vs --workers 1: {t_w1 / t_dask:.2f}x (goal >= 1.7)")
    print(f"Dask (2 workers started) vs --workers 1: {t_w1 / t_warm:.2f}x")
    print(f"tiny inputs: local, one thread {t_tiny_local * 1000 / n:.1f} ms per input; Dask (started) "
          f"{t_tiny_dask * 1000 / n:.1f} ms per input: {(t_tiny_dask - t_tiny_local) / n * 1000:.1f} ms per task more")


if __name__ == "__main__":
    main()
