"""J5: GL_SPHERE_MAP texgen of 1M vertices — spheremap (Python call) vs a plain numpy
implementation of the same GL maths, interleaved in one run, median of repeats.

    python bench/bench_texgen.py [--n 1000000] [--repeat 30]

Goal (2 cores): <= 4 ms through the Python call (<= 1.5 ms for the Rust kernel:
`cargo bench -p spheremap --bench texgen`).
"""

import argparse
import os
import platform
import time

import numpy as np

import spheremap as sm


def numpy_texgen(p, n, mv):
    """GL_SPHERE_MAP with GL_NORMALIZE, vectorised numpy (float32 throughout)."""
    m = mv.astype(np.float32)
    e = p @ m[:3, :3].T + m[:3, 3]
    u = e / np.linalg.norm(e, axis=1, keepdims=True)
    nm = np.linalg.inv(mv)[:3, :3].T.astype(np.float32)
    ne = n @ nm.T
    ne /= np.linalg.norm(ne, axis=1, keepdims=True)
    r = u - 2 * np.sum(ne * u, axis=1, keepdims=True) * ne
    r[:, 2] += 1
    k = 0.5 / np.linalg.norm(r, axis=1)
    r[:, 2] -= 1
    return np.stack([r[:, 0] * k + 0.5, r[:, 1] * k + 0.5], axis=1)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=30)
    a = ap.parse_args()
    rng = np.random.default_rng(0)
    p = rng.normal(size=(a.n, 3)).astype(np.float32)
    n = rng.normal(size=(a.n, 3)).astype(np.float32)
    mv = np.eye(4)
    mv[:3, :3] = [[0.9, 0.1, 0.0], [-0.1, 0.9, 0.2], [0.0, -0.2, 1.1]]
    mv[:3, 3] = [0.2, 0.0, -5.0]
    ours = sm.sphere_texgen(p, n, mv)
    ref = numpy_texgen(p, n, mv)
    ok = np.hypot(ours[:, 0] - 0.5, ours[:, 1] - 0.5) < 0.499
    agree = float(np.abs(ours - ref)[ok].max())
    buf = np.empty((a.n, 2), np.float32)
    times = {"spheremap": [], "spheremap_out": [], "numpy": []}
    calls = (
        ("spheremap", lambda: sm.sphere_texgen(p, n, mv)),
        ("spheremap_out", lambda: sm.sphere_texgen(p, n, mv, out=buf)),
        ("numpy", lambda: numpy_texgen(p, n, mv)),
    )
    for _ in range(a.repeat):
        for name, f in calls:
            t = time.perf_counter()
            f()
            times[name].append(time.perf_counter() - t)
    med = {k: 1e3 * float(np.median(v)) for k, v in times.items()}
    print(f"J5 texgen {a.n} vertices, {os.cpu_count()} cpus, {platform.processor() or platform.machine()}")
    print(f"  spheremap (Python call): {med['spheremap']:.2f} ms (min {1e3 * min(times['spheremap']):.2f})")
    print(f"  spheremap, out= reused : {med['spheremap_out']:.2f} ms (min {1e3 * min(times['spheremap_out']):.2f})")
    print(f"  numpy                  : {med['numpy']:.2f} ms")
    print(f"  ratio numpy/spheremap  : {med['numpy'] / med['spheremap']:.1f}x;  max |diff| {agree:.2g}")


if __name__ == "__main__":
    main()
