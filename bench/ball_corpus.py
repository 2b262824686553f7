"""A corpus of mirror-ball photos with known outlines, and how well spheremap finds the balls.

    python bench/ball_corpus.py make DIR [--cases N] [--seed K]   # render the photos
    python bench/ball_corpus.py eval DIR [--spheremap BIN]         # find the balls, report

`make` photographs the built-in chrome ball (radius 1) inside each HDRI of testdata/hdri with the
ray tracer (16 rays per pixel: the pixels are box-filtered, as a sensor's are), varying what a
real photo varies: the HDRI and which part of it lies behind the ball, the camera distance (3 to
20 radii), the ball's size on the photo (radius 150 to 400 px), its place on the photo (centred
or off-centre: then its outline is an ellipse), its reflectance (0.6 to 1), sensor noise, and
JPEG compression (8-bit sRGB, clipped highlights). Each photo's exact outline is written to
`truth.json`: the ball's silhouette is the cone of half-angle asin(1/D) around the direction of
its centre; its "circle" is the one through the cone's points nearest to and farthest from the
image centre (as `from-photo` reports it).

`eval` finds every photo's ball and reports the errors of the centre and radius, in pixels, and
the confidence the detector gives: `--method rim` (default) calls `spheremap.find_ball(photo,
fov=F)` (the perspective rim model), `--method cli` runs `spheremap from-photo --fov F --json`
(the same model through the CLI), `--method edge` calls `spheremap.find_ball(photo)` (the edge
fit, which assumes nothing about the camera). A refused photo is listed with the error, and with
how far off the best candidate circle it names was.
"""

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
W, H = 1280, 960


def rotation_taking(a, b):
    """The rotation matrix taking unit vector a to unit vector b."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    v = np.cross(a, b)
    c = float(a @ b)
    s = np.linalg.norm(v)
    if s < 1e-12:
        return np.eye(3) if c > 0 else -np.eye(3)
    k = v / s
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * K + (1 - c) * K @ K


def look_frame(forward, up=(0.0, 1.0, 0.0)):
    """Camera -> world rotation of a camera looking along `forward` (gluLookAt)."""
    f = np.asarray(forward, float)
    f /= np.linalg.norm(f)
    up = np.asarray(up, float)
    if abs(f @ up) > 0.95:
        up = np.array([1.0, 0.0, 0.0])
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    return np.stack([s, u, -f], axis=1)


def truth_circle(v, f, beta):
    """The outline circle of a ball whose centre is in camera direction v (unit), angular
    radius beta, seen with focal length f px on a W x H photo."""
    theta = math.acos(max(-1.0, min(1.0, -v[2])))
    if theta < 1e-12:
        return W / 2, H / 2, f * math.tan(beta)
    d = np.array([v[0], -v[1]]) / math.hypot(v[0], v[1])  # image direction (y down)
    r1, r2 = f * math.tan(theta - beta), f * math.tan(theta + beta)
    c = np.array([W / 2, H / 2]) + d * (r1 + r2) / 2
    return float(c[0]), float(c[1]), (r2 - r1) / 2


def make(out: Path, cases: int, seed: int):
    import spheremap as sm

    out.mkdir(parents=True, exist_ok=True)
    hdris = sorted((ROOT / "testdata" / "hdri").glob("*.exr"))
    rng = np.random.default_rng(seed)
    truth = []
    for k in range(cases):
        hdri = hdris[k % len(hdris)]
        env = sm.read_image(hdri)
        dist = float(np.exp(rng.uniform(np.log(3), np.log(20))))
        beta = math.asin(1 / dist)
        r_px = float(rng.uniform(150, 400))
        f = r_px / math.tan(beta)
        fov = math.degrees(2 * math.atan(W / 2 / f))
        # Off-centre for two cases in three: the ball's centre anywhere it stays 30 px inside.
        ox = oy = 0.0
        if k % 3:
            mx, my = W / 2 - r_px * 1.1 - 30, H / 2 - r_px * 1.1 - 30
            ox, oy = rng.uniform(-max(mx, 0), max(mx, 0)), rng.uniform(-max(my, 0), max(my, 0))
        v = np.array([ox / f, -oy / f, -1.0])
        v /= np.linalg.norm(v)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        u[1] = abs(u[1]) * 0.5 * np.sign(rng.uniform(-1, 1))  # mostly near the horizon
        u /= np.linalg.norm(u)
        eye = dist * u
        m0 = look_frame(-u)
        m = m0 @ rotation_taking(v, [0.0, 0.0, -1.0])
        target = eye + m @ np.array([0.0, 0.0, -1.0])
        up = m @ np.array([0.0, 1.0, 0.0])
        refl = float(rng.choice([0.6, 0.75, 0.9, 1.0]))
        scene = sm.Scene.builtin("mirror-ball", reflectance=refl, environment=env)
        t0 = time.time()
        img = scene.preview(eye, target, up=up, fov=fov, size=(W, H), samples=16, seed=k)
        kind = ["clean", "noise", "jpeg"][(k // 2) % 3]
        name = f"{k:03d}_{hdri.stem}_{kind}"
        if kind == "clean":
            path = out / f"{name}.exr"
            sm.write_image(path, img)
        else:
            # Expose so the median lands at 0.18, then shot and read noise (in exposed units).
            img = img * (0.18 / max(float(np.median(img)), 1e-6))
            sigma = 0.002 + 0.01 * np.sqrt(np.maximum(img, 0))
            img = (img + rng.normal(size=img.shape) * sigma).astype(np.float32)
            if kind == "noise":
                path = out / f"{name}.exr"
                sm.write_image(path, img)
            else:
                from PIL import Image

                png = out / f"{name}.tmp.png"
                sm.write_image(png, img)
                path = out / f"{name}.jpg"
                Image.open(png).save(path, quality=int(rng.integers(80, 96)))
                png.unlink()
        cx, cy, r = truth_circle(v, f, beta)
        truth.append(dict(file=path.name, hdri=hdri.stem, kind=kind, distance=dist, fov=fov,
                          reflectance=refl, circle=[cx, cy, r], off_centre=[ox, oy]))
        print(f"{name}: D={dist:.1f} r={r:.1f} fov={fov:.2f} R={refl} ({time.time() - t0:.1f} s)",
              flush=True)
    (out / "truth.json").write_text(json.dumps(truth, indent=1))


def find_in_python(path: Path, fov):
    """find_ball's circle and confidence (fov None: the edge fit), or its error."""
    import spheremap as sm

    try:
        f = sm.find_ball(sm.read_image(path), fov=fov)
    except sm.Error as e:
        return None, str(e)
    return f["circle"], f["confidence"]


def named_candidate(error: str):
    """The best candidate circle a refusal names, if any."""
    import re

    m = re.search(r"candidate circles, \(([-0-9.]+), ([-0-9.]+), ([-0-9.]+)\)", error)
    return [float(m.group(i)) for i in (1, 2, 3)] if m else None


def evaluate(corpus: Path, binary: str, method: str = "rim"):
    import tempfile

    truth = json.loads((corpus / "truth.json").read_text())
    rows = []
    scratch = Path(tempfile.mkdtemp()) / "map.exr"
    for t in truth:
        if method in ("rim", "edge"):
            circle, conf = find_in_python(corpus / t["file"], t["fov"] if method == "rim" else None)
            if circle is None:
                rows.append((t, None, conf))
                named = named_candidate(conf)
                off = "" if named is None else (
                    f" [named candidate off by {max(abs(a - b) for a, b in zip(named, t['circle'])):.3f} px]")
                print(f"{t['file']}: {conf}{off}")
                continue
            shot = {"circle": circle, "confidence": conf}
        else:
            cmd = [*binary.split(), "from-photo", str(corpus / t["file"]), "--fov", repr(t["fov"]), "--size", "16",
                   "--json", "-q", "-o", str(scratch), "--force"]
            r = subprocess.run(cmd, capture_output=True, text=True)
            if r.returncode != 0:
                rows.append((t, None, r.stderr.strip()))
                print(f"{t['file']}: {r.stderr.strip()}")
                continue
            shot = json.loads(r.stdout)["shots"][0]
        cx, cy, rad = shot["circle"]
        e = (cx - t["circle"][0], cy - t["circle"][1], rad - t["circle"][2])
        rows.append((t, e, shot.get("confidence")))
        print(f"{t['file']}: dcx={e[0]:+.3f} dcy={e[1]:+.3f} dr={e[2]:+.3f} "
              f"(r={t['circle'][2]:.0f}, D={t['distance']:.1f}, R={t['reflectance']}) "
              f"confidence={shot.get('confidence')}", flush=True)
    errs = np.array([max(abs(e[0]), abs(e[1]), abs(e[2])) for _, e, _ in rows if e is not None])
    failed = sum(1 for _, e, _ in rows if e is None)
    if len(errs):
        print(f"\n{len(errs)} found, {failed} refused; largest of |dcx|, |dcy|, |dr| per photo: "
              f"median {np.median(errs):.3f} px, 90 % {np.percentile(errs, 90):.3f}, worst {errs.max():.3f}")
        for kind in ["clean", "noise", "jpeg"]:
            k = np.array([max(map(abs, e)) for t, e, _ in rows if e is not None and t["kind"] == kind])
            if len(k):
                print(f"  {kind}: median {np.median(k):.3f}, worst {k.max():.3f} ({len(k)} photos)")
    return rows


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    m = sub.add_parser("make")
    m.add_argument("dir", type=Path)
    m.add_argument("--cases", type=int, default=54)
    m.add_argument("--seed", type=int, default=1)
    e = sub.add_parser("eval")
    e.add_argument("dir", type=Path)
    e.add_argument("--spheremap", default=f"{sys.executable} -m spheremap")
    e.add_argument("--method", choices=["rim", "cli", "edge"], default="rim")
    a = p.parse_args()
    if a.cmd == "make":
        make(a.dir, a.cases, a.seed)
    else:
        evaluate(a.dir, a.spheremap, a.method)


if __name__ == "__main__":
    main()
