"""Draws docs/images/matcaps.png: MatCaps of the bundled HDRI from rough to mirror, and Lambert.

Usage: python3 scripts/lighting_figure.py   (from the repository root, with spheremap installed)
"""

import numpy as np
import spheremap as sm

env = sm.read_image("testdata/apartment.exr")
size = 128
panels = [sm.bake_matcap(env, material="lambert", size=size, samples=1)]
for r in (1.0, 0.5, 0.25, 0.0):
    panels.append(sm.bake_matcap(env, material="ggx", roughness=r, size=size, samples=1))
row = np.concatenate([np.pad(p, ((4, 4), (4, 4), (0, 0))) for p in panels], axis=1)
row = row / (1.0 + row)  # the x/(1+x) tone map; the PNG writer encodes sRGB
sm.write_image("docs/images/matcaps.png", row.astype(np.float32))
print("docs/images/matcaps.png: lambert, ggx 1.0, 0.5, 0.25, 0 (mirror)")
