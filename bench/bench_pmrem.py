"""The peer of `spheremap prefilter`: three.js's PMREMGenerator, timed in headless Chromium on
SwiftShader (software WebGL2: what runs on a machine without a GPU), next to spheremap's own
chain of the same map.

three.js (r187) builds its radiance chain with `fromEquirectangular`: a cube of faces width/4
(256 for a 1024x512 lat-long) with mips down to 8, each level filtered by importance sampling of
the GGX lobe (256 samples per texel, reading the mips by the samples' density) — the same chain
as `spheremap prefilter --to cube --size 256` (6 levels). Each call is timed to the GPU's end (a
readPixels after it), after one warm-up call that compiles its shaders. spheremap's chain of the
same map runs in this process for the comparison (the wheel installed): the sampled method with
256 and 1024 (Filament's) samples, and the tree (at tolerance 1e-2 and at the default).

    python bench/bench_pmrem.py [--rounds 5] [--size 512]

Needs npm (three.js is installed once into bench/.peers, pinned to THREE_VERSION), Playwright
for Python and Chromium (Debian: apt install chromium; SPHEREMAP_CHROMIUM names another binary).
"""

import argparse
import os
import statistics
import subprocess
import time

import numpy as np

import spheremap as sm

from machine import cpu_model

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
PEERS = os.path.join(HERE, ".peers")
THREE_VERSION = "0.187.0"
CHROMIUM = os.environ.get("SPHEREMAP_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"]

PAGE = """<!doctype html><html><body><script type="module">
import * as THREE from './three/build/three.module.js';
const [w, h] = [%d, %d];
const renderer = new THREE.WebGLRenderer();
renderer.setSize(4, 4);
document.body.appendChild(renderer.domElement);
const data = new Float32Array(await (await fetch('env.f32')).arrayBuffer());
const tex = new THREE.DataTexture(data, w, h, THREE.RGBAFormat, THREE.FloatType);
tex.mapping = THREE.EquirectangularReflectionMapping;
tex.needsUpdate = true;
const pmrem = new THREE.PMREMGenerator(renderer);
const gl = renderer.getContext();
const px = new Uint8Array(4);
function sync() {
  renderer.setRenderTarget(null);
  gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
}
window.timePmrem = (rounds) => {
  const times = [];
  let rt = pmrem.fromEquirectangular(tex);  // warm-up: compiles the shaders
  sync();
  const size = [rt.width, rt.texture.mipmaps.length];
  rt.dispose();
  for (let i = 0; i < rounds; i++) {
    const t0 = performance.now();
    rt = pmrem.fromEquirectangular(tex);
    sync();
    times.push(performance.now() - t0);
    rt.dispose();
  }
  return {times, size};
};
window.REVISION = THREE.REVISION;
window.ready = true;
</script></body></html>"""


def three_js():
    """bench/.peers/node_modules/three, installed by npm on first use."""
    pkg = os.path.join(PEERS, "node_modules", "three")
    if not os.path.isfile(os.path.join(pkg, "build", "three.module.js")):
        os.makedirs(PEERS, exist_ok=True)
        subprocess.run(
            ["npm", "install", "--no-save", "--no-audit", "--no-fund", "--prefix", PEERS, f"three@{THREE_VERSION}"],
            check=True,
        )
    return pkg


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--size", type=int, default=512, help="the lat-long's height (width twice it)")
    a = ap.parse_args()
    from playwright.sync_api import sync_playwright

    park = sm.read_image(os.path.join(ROOT, "testdata", "hdri", "park.exr"))[..., :3]
    env = sm.convert(park, "latlong", "latlong", size=a.size)
    h, w = env.shape[:2]
    rgba = np.concatenate([env, np.ones((h, w, 1), np.float32)], -1)
    # three.js's DataTexture rows run bottom-up (flipY is off for data): the map's top row last.
    blob = np.ascontiguousarray(rgba[::-1]).astype("<f4").tobytes()
    three = three_js()
    files = {
        "index.html": PAGE.replace("%d, %d", f"{w}, {h}").encode(),
        "env.f32": blob,
    }

    def serve(route):
        path = route.request.url.split("://peer.local/", 1)[1].split("?")[0]
        if path.startswith("three/"):
            with open(os.path.join(three, path[len("three/") :]), "rb") as f:
                body = f.read()
        elif path in files:
            body = files[path]
        else:
            return route.fulfill(status=404, body="")
        kind = "text/html" if path.endswith(".html") else "text/javascript" if path.endswith(".js") else "application/octet-stream"
        route.fulfill(status=200, body=body, headers={"Content-Type": kind})

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_page()
        page.route("http://peer.local/**", serve)
        page.goto("http://peer.local/index.html")
        page.wait_for_function("window.ready === true", timeout=120_000)
        r = page.evaluate(f"window.timePmrem({a.rounds})")
        version = page.evaluate("window.REVISION")
        browser.close()

    def timed(rounds, **kw):
        times = []
        for _ in range(rounds):
            t = time.perf_counter()
            sm.prefilter(env, to="cube", size=256, levels=6, **kw)
            times.append(time.perf_counter() - t)
        return statistics.median(times) * 1e3

    print(f"CPU: {cpu_model()} ({os.cpu_count()} cores); park.exr as a {w}x{h} lat-long; median of {a.rounds}")
    print(
        f"three.js r{version} PMREMGenerator.fromEquirectangular, Chromium on SwiftShader "
        f"(faces of {r['size'][0]}, {r['size'][1]} levels)  {statistics.median(r['times']):8.0f} ms"
    )
    print(f"spheremap prefilter --to cube --size 256 --method sampled --lobe-samples 256  {timed(a.rounds, method='sampled', lobe_samples=256):8.0f} ms")
    print(f"spheremap prefilter --to cube --size 256 --method sampled (1024 samples)      {timed(a.rounds, method='sampled'):8.0f} ms")
    print(f"spheremap prefilter --to cube --size 256 --tolerance 1e-2 (tree)             {timed(a.rounds, tolerance=1e-2):8.0f} ms")
    print(f"spheremap prefilter --to cube --size 256 (tree, tolerance 1e-4; one run)     {timed(1):8.0f} ms")


if __name__ == "__main__":
    main()
