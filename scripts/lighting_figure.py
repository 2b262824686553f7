"""Draws the lighting figures of docs/lighting.md (with spheremap installed, from the repository
root): docs/images/matcaps.png, MatCaps of the bundled HDRI from rough to mirror and Lambert; and
docs/images/prefilter.png, a prefiltered chain of the same HDRI (Filament's level roughnesses):
on top the exact sphere-map levels of the default view, below the cube levels shown as lat-longs.

Usage: python3 scripts/lighting_figure.py
"""

import numpy as np
import spheremap as sm


def tone(x):
    return (x / (1.0 + x)).astype(np.float32)  # x/(1+x); the PNG writer encodes sRGB


def pad(p, k=4):
    return np.pad(p, ((k, k), (k, k), (0, 0)))


def grow(p, size):
    """Nearest-neighbour enlargement to `size` rows (texels stay visible)."""
    f = size // p.shape[0]
    return np.repeat(np.repeat(p, f, 0), f, 1)


env = sm.read_image("testdata/apartment.exr")
size = 128
panels = [sm.bake_matcap(env, material="lambert", size=size, samples=1)]
for r in (1.0, 0.5, 0.25, 0.0):
    panels.append(sm.bake_matcap(env, material="ggx", roughness=r, size=size, samples=1))
row = np.concatenate([pad(p) for p in panels], axis=1)
sm.write_image("docs/images/matcaps.png", tone(row))
print("docs/images/matcaps.png: lambert, ggx 1.0, 0.5, 0.25, 0 (mirror)")

levels = 6
spheres, rep = sm.prefilter(env, to="sphere", size=128, levels=levels, samples=1, report=True)
cubes = sm.prefilter(env, to="cube", size=128, levels=levels, samples=1, tolerance=1e-4)
top = np.concatenate([pad(grow(s, 128), 8) for s in spheres], axis=1)
ll = [sm.convert(c, "cube", "latlong", size=min(c.shape[1], 64), samples=1) for c in cubes]
bottom = np.concatenate([pad(grow(x, 64), 8) for x in ll], axis=1)
sm.write_image("docs/images/prefilter.png", tone(np.concatenate([top, bottom], axis=0)))
print(
    "docs/images/prefilter.png: levels 0-5, roughness",
    ", ".join(f"{r['roughness']:.3f}" for r in rep),
)
