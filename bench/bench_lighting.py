"""Lighting jobs timed in one run: MatCap bakes (256^2, 4 samples, a 512x256 map) at several
materials, prefiltered cube chains (256^2, 6 levels, one sample per texel, each method), the
irradiance cube (32^2 and 128^2; the peer: the SH9 irradiance evaluated by numpy at the 128^2
cube's texels, what engines do instead), SH9 of a 2048x1024 lat-long (against a vectorised numpy
projection, the obvious peer) and the split-sum table. Median of --rounds calls each.

    python bench/bench_lighting.py [--rounds 3] [--only SUBSTRING]

Goals (2 cores): bake-matcap 256^2 GGX 0.25 <= 1 s; prefilter cube 6x256^2, 6 levels <= 2 s;
SH9 of 2048x1024 <= 5 ms; irradiance cube 128^2 <= 50 ms.
"""

import argparse
import os
import time

import numpy as np

import spheremap as sm

from machine import cpu_model

HERE = os.path.dirname(__file__)


def median_time(f, rounds):
    times = []
    for _ in range(rounds):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def numpy_sh9(env):
    """SH9 radiance coefficients of a lat-long by numpy (the default lat-long preset's
    directions from spheremap, computed once outside the timing)."""
    h, w, _ = env.shape
    return lambda: np.einsum("hwc,hwi->ic", env * OMEGA[..., None], BASIS)


def basis(d):
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack(
        [
            0.282095 + 0 * x,
            0.488603 * y,
            0.488603 * z,
            0.488603 * x,
            1.092548 * x * y,
            1.092548 * y * z,
            0.315392 * (3 * z * z - 1),
            1.092548 * x * z,
            0.546274 * (x * x - y * y),
        ],
        -1,
    )


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--only", default="", help="run only the jobs whose label contains this")
    a = ap.parse_args()
    park = sm.read_image(os.path.join(HERE, "..", "testdata", "hdri", "park.exr"))
    rows = []
    for label, kw in [
        ("bake-matcap lambert", dict(material="lambert")),
        ("bake-matcap ggx 0.5", dict(roughness=0.5)),
        ("bake-matcap ggx 0.25", dict(roughness=0.25)),
    ]:
        if a.only in label + " 256^2":
            rows.append((label + " 256^2", median_time(lambda: sm.bake_matcap(park, size=256, **kw), a.rounds)))
    for label, kw in [
        ("prefilter cube 256, tree 1e-4", {}),
        ("prefilter cube 256, tree 1e-3", dict(tolerance=1e-3)),
        ("prefilter cube 256, tree 1e-2", dict(tolerance=1e-2)),
        ("prefilter cube 256, sampled", dict(method="sampled")),
        ("prefilter irradiance 32, tree", dict(irradiance=True)),
        ("prefilter irradiance 32, sampled", dict(irradiance=True, method="sampled")),
        ("prefilter irradiance 128, tree 1e-4", dict(irradiance=True, size=128)),
        ("prefilter irradiance 128, tree 2e-3", dict(irradiance=True, size=128, tolerance=2e-3)),
        ("prefilter irradiance 128, sampled", dict(irradiance=True, size=128, method="sampled")),
    ]:
        if a.only in label:
            rows.append((label, median_time(lambda: sm.prefilter(park, to="cube", **kw), a.rounds)))
    if a.only in "numpy SH9 irradiance 128 (peer)":
        sh = np.array(sm.irradiance_sh(park)["coefficients"], np.float64)
        f = 128
        v, u = np.mgrid[0 : 6 * f, 0:f]
        cube_dirs, _ = sm.uv_to_dir(np.stack([(u + 0.5) / f, (v + 0.5) / (6 * f)], -1), "cube")
        rows.append(("numpy SH9 irradiance 128 (peer)", median_time(lambda: sh9_irradiance(sh, cube_dirs), a.rounds)))
    if not any(a.only in k for k in ("irradiance_sh 2048x1024", "numpy SH9 2048x1024 (peer)", "dfg_lut 128")):
        report(rows)
        return
    big = np.random.default_rng(0).random((1024, 2048, 3), dtype=np.float32)
    global OMEGA, BASIS
    OMEGA = sm.texel_solid_angles("latlong", 2048, 1024).reshape(1024, 2048)
    v, u = np.mgrid[0:1024, 0:2048]
    dirs, _ = sm.uv_to_dir(np.stack([(u + 0.5) / 2048, (v + 0.5) / 1024], -1), "latlong")
    BASIS = basis(dirs)
    rows.append(("irradiance_sh 2048x1024", median_time(lambda: sm.irradiance_sh(big), max(a.rounds, 5))))
    rows.append(("numpy SH9 2048x1024 (peer)", median_time(numpy_sh9(big), max(a.rounds, 5))))
    rows.append(("dfg_lut 128", median_time(lambda: sm.dfg_lut(128), a.rounds)))
    report(rows)


def report(rows):
    print(f"CPU: {cpu_model()}, {os.cpu_count()} threads")
    for label, t in rows:
        print(f"{label:36s} {t:8.3f} s")


def sh9_irradiance(sh, dirs):
    """three.js's SphericalHarmonics3.getIrradianceAt at every direction: the coefficients
    (9 x 3) times the basis, with the cosine lobe's band factors pi, 2pi/3, pi/4."""
    b = basis(dirs)
    band = np.array([np.pi] + [2 * np.pi / 3] * 3 + [np.pi / 4] * 5)
    return np.einsum("...i,ic->...c", b * band, sh)


if __name__ == "__main__":
    main()
