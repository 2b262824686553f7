"""Conversion jobs J1-J4 side by side in one run: spheremap (Python call, in-memory image) vs
skylibs, py360convert, a vectorised numpy bilinear remap and OpenCV ``remap`` (when installed:
``pip install opencv-python-headless``). Each job's contenders run interleaved, one call each per
round (median of 9 rounds: every call follows the others', as in a pipeline); "alone" is the
median of calls in a row (warm caches); "x" is the interleaved median over spheremap's.

    python bench/bench_convert.py [--rounds 9] [--repeat 7] [--jobs J1,J2,J3,J4,RT]

Goals (2 cores): J1 latlong 2048x1024 -> sphere 1024^2, 1 sample <= 6 ms;
J2 cube 6x512^2 -> sphere 1024^2 <= 5 ms; J3 sphere 1024^2 -> latlong 2048x1024 <= 8 ms;
J4 = J1 with 16 samples <= 50 ms; RT cube 6x256^2 -> sphere 512^2 <= 2 ms.
"""

import argparse
import os
import time

import numpy as np

import spheremap as sm

from machine import cpu_model


def j1_maps(h, w, n):
    """Source pixel coordinates (texel centres at integers) of every texel of an n x n GL sphere
    map in an h x w lat-long (skylibs preset: u = 1/2 + atan2(x, -z)/2pi), and the disc mask."""
    c = (np.arange(n, dtype=np.float32) + 0.5) / n * 2 - 1
    a, b = np.meshgrid(c, -c)
    d2 = a * a + b * b
    z = np.sqrt(np.maximum(1 - d2, 0))
    x, y, zz = 2 * z * a, 2 * z * b, 1 - 2 * d2
    u = (0.5 + np.arctan2(x, -zz) / (2 * np.pi)) % 1.0 * w - 0.5
    v = np.arctan2(np.hypot(x, zz), y) / np.pi * h - 0.5
    return u, v, d2 <= 1


def numpy_j1(ll, n):
    """latlong -> GL sphere map, one bilinear tap, vectorised numpy."""
    h, w, _ = ll.shape
    u, v, disc = j1_maps(h, w, n)
    x0 = np.floor(u).astype(np.int64)
    y0 = np.clip(np.floor(v).astype(np.int64), 0, h - 2)
    fx, fy = (u - x0)[..., None], np.clip(v - y0, 0, 1)[..., None]
    x0 %= w
    x1 = (x0 + 1) % w
    top = ll[y0, x0] * (1 - fx) + ll[y0, x1] * fx
    bot = ll[y0 + 1, x0] * (1 - fx) + ll[y0 + 1, x1] * fx
    return np.where(disc[..., None], top * (1 - fy) + bot * fy, 0)


def opencv_j1(cv2, ll, n):
    """Same maps as numpy_j1, built per call, then cv2.remap (bilinear, wrap)."""
    h, w, _ = ll.shape
    u, v, _ = j1_maps(h, w, n)
    mx, my = u.astype(np.float32), v.astype(np.float32)
    return cv2.remap(ll, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)


def opencv_j4(cv2, ll, n):
    """J4's 16 samples per texel the OpenCV way: remap at 4x the size (4x4 samples per texel, at
    the sub-texel centres) then INTER_AREA down to n x n (their box average)."""
    h, w, _ = ll.shape
    u, v, _ = j1_maps(h, w, 4 * n)
    big = cv2.remap(ll, u.astype(np.float32), v.astype(np.float32), cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
    return cv2.resize(big, (n, n), interpolation=cv2.INTER_AREA)


def median_ms(f, repeat):
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        ts.append((time.perf_counter() - t) * 1e3)
    return float(np.median(ts)), float(min(ts))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--jobs", default="J1,J2,J3,J4,RT")
    args = ap.parse_args()
    rng = np.random.default_rng(1)
    ll = rng.random((1024, 2048, 3), dtype=np.float32)
    cube512 = rng.random((6, 512, 512, 3), dtype=np.float32)
    cube256 = rng.random((6, 256, 256, 3), dtype=np.float32)
    sphere = rng.random((1024, 1024, 3), dtype=np.float32)
    peers = {}
    try:
        from envmap import EnvironmentMap

        def sky(img, src, dst, n):
            e = EnvironmentMap(img, src, copy=True)
            e.convertTo(dst, n)
            return e.data

        peers["skylibs"] = sky
    except ImportError:
        pass
    try:
        import cv2

        cv2.setNumThreads(os.cpu_count() or 2)
        peers["opencv"] = cv2
    except ImportError:
        pass
    try:
        import py360convert

        peers["py360convert"] = py360convert
    except ImportError:
        pass

    jobs = {
        "J1": [("spheremap", lambda **kw: sm.convert(ll, "latlong", "sphere", size=1024, samples=1, **kw)),
               ("numpy", lambda: numpy_j1(ll, 1024))],
        "J2": [("spheremap", lambda **kw: sm.convert(cube512, "cube", "sphere", size=1024, samples=1, **kw))],
        "J3": [("spheremap", lambda **kw: sm.convert(sphere, "sphere", "latlong", size=1024, samples=1, **kw))],
        "J4": [("spheremap", lambda **kw: sm.convert(ll, "latlong", "sphere", size=1024, samples=16, max_samples=16, **kw))],
        "RT": [("spheremap", lambda **kw: sm.convert(cube256, "cube", "sphere", size=512, samples=1, **kw))],
    }
    # The same calls writing into a reused result buffer (out=): no first touch of fresh pages.
    bufs = {"J1": (1024, 1024), "J2": (1024, 1024), "J3": (1024, 2048), "J4": (1024, 1024), "RT": (512, 512)}
    for name, (h, w) in bufs.items():
        buf = np.empty((h, w, 3), np.float32)
        call = jobs[name][0][1]
        jobs[name].insert(1, ("spheremap, out= buffer", lambda call=call, buf=buf: call(out=buf)))
    if "skylibs" in peers:
        jobs["J1"].append(("skylibs", lambda: peers["skylibs"](ll, "latlong", "sphere", 1024)))
        jobs["J3"].append(("skylibs", lambda: peers["skylibs"](sphere, "sphere", "latlong", 1024)))
    if "opencv" in peers:
        jobs["J1"].append(("opencv remap (maps per call)", lambda: opencv_j1(peers["opencv"], ll, 1024)))
        jobs["J4"].append(("opencv remap 4096^2 + INTER_AREA (maps per call)",
                           lambda: opencv_j4(peers["opencv"], ll, 1024)))
    if "py360convert" in peers:
        dice = sm.cube_to_layout(cube512, "dice")
        jobs["J3"].append(("py360convert c2e (cube 512 -> 2048x1024)",
                           lambda: peers["py360convert"].c2e(dice, 1024, 2048, cube_format="dice")))
    print(f"# {cpu_model()}, {os.cpu_count()} cpus; interleaved: {args.rounds} rounds, each calling every "
          f"contender once; alone: {args.repeat} calls in a row")
    for name in args.jobs.split(","):
        contenders = jobs[name]
        for _, f in contenders:
            f()  # warm up
        # Interleaved, as a user's pipeline runs: each call follows the others' (cold caches,
        # memory the others freed).
        times = {label: [] for label, _ in contenders}
        for _ in range(args.rounds):
            for label, f in contenders:
                t = time.perf_counter()
                f()
                times[label].append((time.perf_counter() - t) * 1e3)
        base = float(np.median(times[contenders[0][0]]))
        for label, f in contenders:
            med, best = float(np.median(times[label])), min(times[label])
            alone = median_ms(f, args.repeat)[0]
            print(f"{name:3} {label:50} median {med:9.2f} ms  best {best:9.2f} ms  alone {alone:9.2f} ms  "
                  f"x{med / base:6.1f}")


if __name__ == "__main__":
    main()
