"""Sampling analytics of a mapping and per-vertex interpolation error of a mesh."""

from __future__ import annotations

from typing import Any

import os

import numpy as np
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
    (sa, an, res), summary = _ext.analyze_mapping(mapping=mapping, preset=preset, map=map, size=size)
    h, w = sa.shape
    out = {
        "mapping": mapping,
        "width": w,
        "height": h,
        "solid_angle": sa,
        "anisotropy": an,
        "resolution_deg": res,
        "stats": {
            "solid_angle": summary["solid_angle_sr"],
            "anisotropy": summary["anisotropy"],
            "resolution_deg": summary["resolution_deg"],
        },
        "summary": summary,
    }
    if mesh is not None:
        cam = _camera(eye, target, up, fovy, near, far, view_size, "view_size")
        m = _ext.analyze_mesh(mesh=mesh, request=_fields(cam), threshold=threshold)
        err, in_view, heat, ms = m["triangle_error_deg"], m["in_view"], m["heat"], m["summary"]
        out["mesh"] = {
            "triangle_error_deg": err,
            "in_view": in_view,
            "split": m["split"],
            "over": np.nonzero(in_view & (err > threshold))[0],
            "uniform_split": ms["uniform_split"],
            "triangles_after_adaptive": ms["triangles_after_adaptive"],
            "unfixable": ms["unfixable"],
            "max_split": ms["max_split"],
            "pixel_error_deg": np.where(heat[..., 1] > 0, heat[..., 0], np.nan),
        }
        summary["mesh"] = ms
    return out
