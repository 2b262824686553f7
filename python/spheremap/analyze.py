"""Sampling analytics of a mapping and per-vertex interpolation error of a mesh."""

from __future__ import annotations

from typing import Any

import os

import numpy.typing as npt

from . import _spheremap as _ext
from ._args import _Photo, _fields
from .render import _camera


def analyze(
    map: _Photo | None = None,
    *,
    mapping: str = "sphere",
    preset: str | None = None,
    size: int = 256,
    mesh: str | os.PathLike[str] | tuple[npt.ArrayLike, npt.ArrayLike | None, npt.ArrayLike] | None = None,
    eye: npt.ArrayLike | None = None,
    target: npt.ArrayLike | None = None,
    up: npt.ArrayLike | None = None,
    fovy: float = 40.0,
    near: float | None = None,
    far: float | None = None,
    view_size: tuple[int, int] = (512, 512),
    threshold: float = 1.0,
) -> dict[str, Any]:
    """Sampling analytics (``spheremap analyze``; definitions in the README).

    map: an environment map (array or path) whose canvas is analysed as `mapping`; without it,
        the `mapping` canvas of `size` N (1 to 8192).
    Returns a dict: "solid_angle" (sr), "anisotropy", "resolution_deg" (the coarsest angular
    step per texel), each (H, W) float64 with NaN off the map, "stats" (min/max/mean and the
    count of texels of each) and "summary": what ``spheremap analyze --json`` prints, the same
    fields. With `mesh` (a path or (positions, normals or None, triangles)) and a camera as
    render: "mesh" = {"triangle_error_deg" (M,), "in_view" (M,), "split" (M,) (the advised
    split per triangle: edges in k, k*k pieces; max_split + 1 = cannot get under the
    threshold), "over" (indices of triangles in view over `threshold` degrees),
    "uniform_split", "triangles_after_adaptive", "unfixable", "pixel_error_deg" ((H, W), NaN
    where no surface)}.
    """
    # The core's analysis request (spheremap::jobs::analyze::AnalyzeRequest) checks every field.
    cam = _camera(eye, target, up, fovy, near, far, view_size, "view_size")
    request = _fields(dict(mapping=mapping, preset=preset, size=size, threshold=threshold, **cam))
    return _ext.analyze(map=map, mesh=mesh, request=request)
