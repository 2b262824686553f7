#!/usr/bin/env python3
"""Ray-traced sphere maps: spheremap's tracer (obvhs BVH) against Embree, side by side.

One run, same machine, same scene, same rays:

* the scene: a procedural ~100k-triangle world (a noisy terrain around the viewer, a ring of
  tessellated spheres, emissive materials), written as OBJ + MTL and loaded by both;
* the rays: exactly those `spheremap.generate` fires for a 512^2 sphere map with 16 rays per
  texel (captured once through a Python fire_ray);
* closest-hit throughput: Embree (embreex, `pip install embreex`; two Python threads, it
  releases the GIL, so both tracers use the 2 cores) vs `spheremap.Scene.intersect`;
* the headline job: `spheremap.generate(512, scene, samples=16, max_samples=16)` with emission
  shading (the goal: <= 1.0 s), and the default adaptive sampling (more rays at the rim).

Usage: python bench/bench_generate.py [--size 512] [--repeat 3]
"""

import argparse
import os
import tempfile
import threading
import time

import numpy as np

import spheremap as sm


def write_scene(folder: str) -> str:
    rng = np.random.default_rng(1)
    verts, faces, groups = [], [], []

    def add(v, f, group):
        base = sum(len(x) for x in verts)
        verts.append(v)
        faces.append(f + base)
        groups.append((group, len(f)))

    # Terrain: (n x n) grid, y = gentle noise, around the viewer.
    n = 200
    x = np.linspace(-40, 40, n + 1)
    gx, gz = np.meshgrid(x, x)
    gy = -0.2 + 0.6 * np.sin(gx * 0.3) * np.cos(gz * 0.23) + 0.1 * rng.standard_normal(gx.shape)
    gy[np.hypot(gx, gz) < 3] = -0.2
    v = np.stack([gx, gy, gz], -1).reshape(-1, 3)
    i = np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]
    f = np.concatenate([np.stack([i, i + n + 1, i + 1], -1).reshape(-1, 3),
                        np.stack([i + 1, i + n + 1, i + n + 2], -1).reshape(-1, 3)])
    add(v, f, "ground")
    # A ring of UV spheres.
    for k in range(24):
        a = 2 * np.pi * k / 24
        c = np.array([9 * np.cos(a), 1.5 + np.sin(3 * a), 9 * np.sin(a)])
        nu, nv = 32, 16
        th = np.linspace(0, np.pi, nv + 1)[:, None]
        ph = np.linspace(0, 2 * np.pi, nu + 1)[None, :]
        sv = np.stack([np.sin(th) * np.cos(ph), np.cos(th) + 0 * ph, np.sin(th) * np.sin(ph)], -1)
        sv = (c + 1.2 * sv).reshape(-1, 3)
        j = np.arange(nv)[:, None] * (nu + 1) + np.arange(nu)[None, :]
        sf = np.concatenate([np.stack([j, j + 1, j + nu + 1], -1).reshape(-1, 3),
                             np.stack([j + 1, j + nu + 2, j + nu + 1], -1).reshape(-1, 3)])
        add(sv, sf, f"ball{k % 3}")
    obj = os.path.join(folder, "bench.obj")
    with open(os.path.join(folder, "bench.mtl"), "w") as m:
        m.write("newmtl ground\nKe 0.3 0.25 0.2\nKd 0 0 0\n")
        for k, c in enumerate(["1 0.2 0.1", "0.1 1 0.2", "0.2 0.3 1"]):
            m.write(f"newmtl ball{k}\nKe {c}\nKd 0 0 0\n")
    with open(obj, "w") as o:
        o.write("mtllib bench.mtl\n")
        for v in verts:
            np.savetxt(o, v, fmt="v %.6f %.6f %.6f")
        for f, (g, _) in zip(faces, groups):
            o.write(f"usemtl {g}\n")
            np.savetxt(o, f + 1, fmt="f %d %d %d")
    return obj, np.concatenate(verts), np.concatenate(faces)



def best(f, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        r = f()
        times.append(time.perf_counter() - t)
    return min(times), r


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    pos = (0.0, 1.0, 0.0)
    with tempfile.TemporaryDirectory() as d:
        obj, v, f = write_scene(d)
        t, scene = best(lambda: sm.Scene.load(obj, shading="emission"), 1)
        print(f"scene: {scene.triangle_count} triangles, loaded + BVH built in {t:.2f} s")

    # The rays a 16-per-texel generation fires (captured once).
    chunks = []

    def capture(o, dd):
        chunks.append((o.copy(), dd.copy()))
        return np.zeros((len(o), 1), np.float32)

    sm.generate(a.size, capture, pos=pos, samples=16, max_samples=16)
    origins = np.concatenate([c[0] for c in chunks[1:]])
    dirs = np.concatenate([c[1] for c in chunks[1:]])
    k = len(dirs)
    print(f"rays: {k} ({a.size}^2 sphere map, 16 per texel, {k / (np.pi / 4 * a.size ** 2):.1f} per disc texel)")

    rows = []
    t_ours, t_hit = best(lambda: scene.intersect(origins, dirs), a.repeat)
    rows.append(("spheremap Scene.intersect (closest hit)", t_ours, k / t_ours))
    try:
        from embreex import rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh
        es = rtcs.EmbreeScene()
        TriangleMesh(es, v[f].astype(np.float32))
        half = k // 2

        def embree_two_threads():
            out = [None, None]

            def work(i, s):
                out[i] = es.run(origins[s], dirs[s], output=1)["tfar"]
            th = [threading.Thread(target=work, args=(0, slice(0, half))),
                  threading.Thread(target=work, args=(1, slice(half, k)))]
            [x.start() for x in th]
            [x.join() for x in th]
            return np.concatenate(out)
        t_emb, t_e = best(embree_two_threads, a.repeat)
        rows.append(("Embree 4 (embreex, 2 threads)", t_emb, k / t_emb))
        hit = np.isfinite(t_hit) & (t_e < 1e30)
        agree = np.mean(np.abs(t_hit[hit] - t_e[hit]) <= 1e-3 * np.maximum(1, t_e[hit]))
        miss_agree = np.mean(np.isfinite(t_hit) == (t_e < 1e30))
        print(f"same hits: {100 * miss_agree:.3f} % hit/miss agree, {100 * agree:.3f} % distances within 1e-3")
    except ImportError:
        t_emb = None
        print("embreex not installed: pip install embreex")
    print(f"\n{'closest-hit throughput':44s} {'time':>9s} {'Mrays/s':>9s}")
    for name, t, r in rows:
        print(f"{name:44s} {t * 1e3:7.1f}ms {r / 1e6:9.2f}")
    if t_emb:
        print(f"ratio spheremap / Embree: {t_emb / t_ours:.2f}x (goal >= 0.6x)")

    print(f"\n{'generate (emission shading)':44s} {'time':>9s} {'rays':>10s} {'Mrays/s':>9s}")
    for label, kw in [("16 rays per texel (max_samples=16)", dict(samples=16, max_samples=16)),
                      ("samples=16, adaptive (default cap 1024)", dict(samples=16)),
                      ("samples=4 (default)", dict(samples=4))]:
        t, _ = best(lambda: sm.generate(a.size, scene, pos=pos, **kw), a.repeat)
        n_rays = count_rays(a.size, pos, kw)
        print(f"{label:44s} {t * 1e3:7.0f}ms {n_rays:10d} {n_rays / t / 1e6:9.2f}")
    print("goal: 512^2 with 16 rays per texel of a 100k-triangle scene <= 1.0 s (2 cores)")


def count_rays(size, pos, kw):
    n = [0]

    def count(o, d):
        n[0] += len(o)
        return np.zeros((len(o), 1), np.float32)
    sm.generate(size, count, pos=pos, **kw)
    return n[0] - 1


if __name__ == "__main__":
    main()
