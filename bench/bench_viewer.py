"""The viewer in headless Chromium on SwiftShader (software WebGL2, what a machine without a GPU
draws with): time from navigation to the first drawn frame, and milliseconds per frame with the
sphere map re-targeted every frame (live) and kept (frozen), for the teapot with a 2048x1024
lat-long at 800x600. Median of --rounds page loads.

    python bench/bench_viewer.py [--rounds 3] [--cli target/release/spheremap]
        [--screenshot docs/images/viewer.png]

--screenshot also writes a picture of the whole page (the README's). Needs Playwright for Python
and Chromium (Debian: apt install chromium; SPHEREMAP_CHROMIUM names another binary).
Goals: first frame <= 3 s under SwiftShader; 60 fps (16.7 ms) with re-targeting on a GPU.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile

from machine import cpu_model

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
TEAPOT = os.path.join(ROOT, "crates/spheremap/data/teapot.obj")
ENV = os.path.join(ROOT, "testdata/apartment.exr")
CHROMIUM = os.environ.get("SPHEREMAP_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--cli", help="the spheremap binary (default: python -m spheremap)")
    ap.add_argument("--screenshot", help="write a PNG of the whole page here")
    a = ap.parse_args()
    from playwright.sync_api import sync_playwright

    cmd = [a.cli] if a.cli else [sys.executable, "-m", "spheremap"]
    with tempfile.TemporaryDirectory() as tmp:
        env = os.path.join(tmp, "apartment_1024.exr")
        subprocess.run(
            [*cmd, "convert", ENV, env, "--from", "latlong", "--to", "latlong", "--size", "1024"], check=True
        )
        server = subprocess.Popen(
            [*cmd, "view", TEAPOT, "--env", env, "--no-browser"], stdout=subprocess.PIPE, text=True
        )
        try:
            url = server.stdout.readline().strip()
            with sync_playwright() as pw:
                browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
                first, live, frozen = [], [], []
                for _ in range(a.rounds):
                    page = browser.new_page(viewport={"width": 1280, "height": 720})
                    page.goto(url + "?size=800,600&mode=per-vertex")
                    page.wait_for_function("window.spheremap !== undefined")
                    page.evaluate("window.spheremap.ready")
                    first.append(page.evaluate("window.spheremap.timing.firstFrameMs"))
                    live.append(page.evaluate(f"window.spheremap.benchmark({a.frames})"))
                    page.evaluate("window.spheremap.set({freeze: 1})")
                    frozen.append(page.evaluate(f"window.spheremap.benchmark({a.frames}, false)"))
                    page.close()
                if a.screenshot:
                    page = browser.new_page(viewport={"width": 1180, "height": 900})
                    page.goto(url + "?size=900,600&mode=per-vertex&eye=0,14,38&tonemap=aces")
                    page.wait_for_function("window.spheremap !== undefined")
                    page.evaluate("window.spheremap.ready")
                    page.screenshot(path=a.screenshot, clip={"x": 0, "y": 0, "width": 1180, "height": 740})
                    page.close()
                browser.close()
        finally:
            server.terminate()
            server.wait(timeout=10)
    print(
        f"CPU: {cpu_model()} ({os.cpu_count()} cores); Chromium on SwiftShader; teapot, 2048x1024 lat-long, "
        f"800x600, median of {a.rounds}"
    )
    print(f"first frame            {statistics.median(first):8.0f} ms")
    print(
        f"frame, live re-target  {statistics.median(live):8.1f} ms  ({1000 / statistics.median(live):.1f} fps)"
    )
    print(
        f"frame, frozen map      {statistics.median(frozen):8.1f} ms  ({1000 / statistics.median(frozen):.1f} fps)"
    )


if __name__ == "__main__":
    main()
