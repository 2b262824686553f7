"""Compressed textures timed in one run: a 256^2 cube with its 6-level chain (about 524 k texels,
each level resampled from the HDRI) written by spheremap.write_texture in every texture
encoding, with the file size, each level's power error against the uncompressed level and the
RMSLE, beside what the encoder alone gave (ISPC's BC6H `basic` preset, Basis Universal's own
UASTC HDR 4x4 / ASTC HDR 6x6: the report's *_unrepaired fields, measured in the same run).
Median of --rounds writes each.

    python bench/bench_compress.py [--rounds 3] [--hdri testdata/hdri/studio.exr ...]

Goals (2 cores): BC6H <= 0.5 s; UASTC HDR 4x4 with Zstandard <= 3 s; every level within
+-0.5 % of the uncompressed level's power.
"""

import argparse
import os
import tempfile
import time
import warnings

import numpy as np

import spheremap as sm

from machine import cpu_model

HERE = os.path.dirname(__file__)
ROOT = os.path.join(HERE, "..")

ENCODINGS = [("float", None, True), ("bc6h", None, False), ("bc6h", 19, False), ("rgb9e5", None, False),
             ("rgb9e5", 19, False), ("uastc-hdr-4x4", 19, False), ("astc-hdr-6x6", 19, False)]


def chain(path, size=256, levels=6):
    env = sm.read_image(path)
    return [sm.convert(env, "latlong", "cube", size=max(1, size >> i)) for i in range(levels)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--hdri", nargs="*", default=[os.path.join(ROOT, "testdata", "hdri", n)
                                                   for n in ("studio.exr", "park.exr")])
    a = ap.parse_args()
    # The bundled HDRIs' negative lobes and values beyond a format's range are folded into
    # their neighbours with a warning per level; the table's power columns state the result.
    warnings.filterwarnings("ignore", message=".*outside .* range")
    print(f"CPU: {cpu_model()}; {os.cpu_count()} logical CPUs")
    print("| map | encoding | zstd | MiB | s (median) | worst level power error | alone | RMSLE (worst level) | alone |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for path in a.hdri:
            levels = chain(path)
            name = os.path.splitext(os.path.basename(path))[0]
            for enc, zstd, half in ENCODINGS:
                out = os.path.join(tmp, f"{name}_{enc}.ktx2")
                times, rep = [], None
                try:
                    for _ in range(a.rounds):
                        t = time.perf_counter()
                        rep = sm.write_texture(out, levels, cube=True, encode=enc, zstd=zstd, half=half,
                                               mapping="cube")
                        times.append(time.perf_counter() - t)
                except sm.Error as e:
                    print(f"| {name} | {enc} | {zstd or '-'} | – | – | {e} | | | |")
                    continue
                mib = os.path.getsize(out) / 2**20
                if rep is None:
                    row = "0 (float)", "–", "0", "–"
                else:
                    worst = lambda key: max(max(abs(x) for x in r[key]) for r in rep)  # noqa: E731
                    row = (f"{100 * worst('power_error'):.2f} %", f"{100 * worst('power_error_unrepaired'):.2f} %",
                           f"{max(r['rmsle'] for r in rep):.4f}", f"{max(r['rmsle_unrepaired'] for r in rep):.4f}")
                print(f"| {name} | {enc}{' half' if half else ''} | {zstd or '-'} | {mib:.2f} | "
                      f"{float(np.median(times)):.3f} | {row[0]} | {row[1]} | {row[2]} | {row[3]} |")


if __name__ == "__main__":
    main()
