"""Directions and image coordinates in every mapping, and exact texel solid angles."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from . import _spheremap as _ext
from ._args import _ArrayLike


def dir_to_uv(
    dirs: _ArrayLike, mapping: str = "latlong", *, preset: str | None = None
) -> npt.NDArray[np.float64]:
    """World directions (..., 3) -> image coordinates (u, v) (..., 2) of `mapping` in
    `preset`'s convention: u = x/W to the right, v = y/H DOWN (row 0 at the top), for every
    mapping. mapping "sphere" (presets as `presets()`, default "gl"; u = s, v = 1 - t),
    "latlong" (presets blender (default), threejs, skylibs, filament, mitsuba, pbrt),
    "angular" (Debevec light probe: centre -Z ahead, rim +Z; preset "debevec") or
    "octahedral" (pbrt-v4 equal-area, pbrt's Z-up frame = ours (x, z, y); preset "pbrt").
    NaN where a direction has no single position."""
    return _ext.dir_to_uv(dirs=dirs, mapping=mapping, preset=preset)


def uv_to_dir(
    uv: _ArrayLike, mapping: str = "latlong", *, preset: str | None = None
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
    """Image coordinates (u, v) (..., 2), v down -> (unit directions (..., 3), valid (...)).
    Lat-long u wraps; points outside a mapping's domain are NaN and invalid."""
    d = _ext.uv_to_dir(uv=uv, mapping=mapping, preset=preset)
    return d, ~np.isnan(d[..., 0])


def texel_solid_angles(
    mapping: str, width: int, height: int | None = None, *, preset: str | None = None
) -> npt.NDArray[np.float64]:
    """Exact solid angle (sr) of every texel of a height x width canvas of `mapping` (height
    defaults to width/2 for "latlong" and "paraboloid", 6*width for "cube" — the face stack —
    else width); sums to 4 pi (angular and paraboloid: to 1e-7, by quadrature; the others
    exactly)."""
    return _ext.texel_solid_angles(mapping=mapping, width=width, height=height, preset=preset)
