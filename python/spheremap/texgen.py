"""GL_SPHERE_MAP texgen for meshes, the sphere mapping of directions, MatCap lookups and the presets of other tools."""

from __future__ import annotations

from typing import Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from . import _spheremap as _ext
from ._args import _ArrayLike, _Float


def sphere_texgen(
    positions: _ArrayLike,
    normals: _ArrayLike,
    modelview: _ArrayLike,
    *,
    normalize: Literal["on", "off", "rescale"] = "on",
    singular: Literal["nan", "center"] = "nan",
    precision: Literal["f32", "f64"] = "f32",
    out: npt.NDArray[_Float] | None = None,
) -> npt.NDArray[_Float]:
    """GL_SPHERE_MAP texture coordinates, exactly as OpenGL computes them.

    positions: (N, 3) or (N, 4) object-space positions (w is used for the eye position, ignored
        for the view direction, as GL does).
    normals: (N, 3) object-space normals.
    modelview: (4, 4) in numpy's math convention (eye = modelview @ p).
    normalize: "on" (GL_NORMALIZE), "off" (normal used as transformed, NOT normalized — as GL),
        "rescale" (GL_RESCALE_NORMAL).
    singular: "nan" (current Mesa: NaN where r = (0,0,-1), for a zero normal with normalize="on",
        and for a vertex at the eye) or "center" (legacy Mesa / Blender Cycles: (1/2, 1/2)).
    precision: "f32" (what GL computes; float32 result) or "f64" (the float64 reference path;
        float64 result).

    out: optional writable C-contiguous (N, 2) array of the result's dtype to write into and
        return (saves allocating, and first-touching, a fresh result for every call).

    Returns (N, 2) (s, t). float64 input is rounded to float32 on the f32 path, as GL does.
    """
    return _ext.sphere_texgen(**locals())


def dir_to_sphere(dirs: _ArrayLike, *, singular: Literal["nan", "center"] = "nan") -> npt.NDArray[_Float]:
    """Directions (..., 3) (any non-zero length, eye frame) -> sphere-map (s, t) (..., 2).

    The dtype follows the input (float32 runs the float32 path). Zero or non-finite directions
    give NaN; directions parallel to (0,0,-1) (the rim) give NaN or (1/2, 1/2) per `singular`.
    Uses a cancellation-free form of GL's formula near the rim.
    """
    return _ext.dir_to_sphere(dirs=dirs, singular=singular)


def sphere_to_dir(st: _ArrayLike) -> tuple[npt.NDArray[_Float], npt.NDArray[np.bool_]]:
    """Sphere-map (s, t) (..., 2) -> (unit directions (..., 3), valid (...) bool).

    Outside the disc (and for non-finite input) the direction is NaN and valid is False.
    """
    dirs = _ext.sphere_to_dir(st)
    return dirs, ~np.isnan(dirs[..., 0])


def reflect(incident: _ArrayLike, normal: _ArrayLike) -> npt.NDArray[_Float]:
    """Mirror reflection ``u - 2 (n.u) n`` of incident directions (..., 3) about normals (..., 3)
    (broadcast against each other). Normals are used as given, as GL does."""
    return _ext.reflect(incident=incident, normal=normal)


def matcap_uv(
    normals: _ArrayLike,
    positions: _ArrayLike | None = None,
    *,
    variant: Literal["classic", "threejs", "perspective"] = "classic",
    scale: float | None = None,
) -> npt.NDArray[_Float]:
    """MatCap texture coordinates (..., 2) (v up, like t) for eye-space normals (..., 3).

    variant: "classic" (n.xy/2 + 1/2), "threejs" (MeshMatcapMaterial's view basis, scale 0.495),
        "perspective" (the normal expressed in the frame of its own view ray: see the README).
    positions: eye-space positions (..., 3) of the shaded points, used by "threejs" and
        "perspective"; None means an orthographic view (view ray -Z everywhere).
    scale: radius factor (default 0.5, or 0.495 for "threejs").
    """
    return _ext.matcap_uv(normals=normals, positions=positions, variant=variant, scale=scale)


def sphere_texel_solid_angle(size: int) -> npt.NDArray[np.float64]:
    """Exact solid angle (sr) of every texel of a size x size sphere map, (size, size) float64.

    Texels wholly inside the disc subtend 16/size**2 sr (the map is equal-area); texels cut by
    the rim get 16 x their area inside the disc; the total is 4 pi.
    """
    return _ext.sphere_texel_solid_angle(size)


class Preset(NamedTuple):
    """A named sphere-map convention: `frame` maps the preset's directions to ours
    (ours = frame @ d); `rows` is "top-is-t1" (file order) or "top-is-t0" (GL upload order);
    `v_down` means the preset's texture coordinate v is 1 - t."""

    name: str
    doc: str
    frame: np.ndarray
    rows: str
    v_down: bool


def presets() -> dict[str, Preset]:
    """The named conventions (``gl`` is ours), by name."""
    return {p[0]: Preset(p[0], p[1], np.array(p[2]), p[3], p[4]) for p in _ext.presets()}


def dir_to_pixel(
    dirs: _ArrayLike, size: int, *, preset: str = "gl", singular: Literal["nan", "center"] = "nan"
) -> npt.NDArray[np.float64]:
    """Directions (..., 3) in `preset`'s frame -> continuous pixel coordinates (x, y) (..., 2) in
    that preset's size x size image: (0, 0) is the top-left corner of row 0, pixel centres are at
    i + 1/2. NaN where a direction has no single pixel."""
    return _ext.dir_to_pixel(dirs=dirs, size=size, preset=preset, singular=singular)


def pixel_to_dir(
    xy: _ArrayLike, size: int, *, preset: str = "gl"
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
    """Continuous pixel coordinates (..., 2) in `preset`'s size x size image -> (unit directions
    in the preset's frame (..., 3), valid (...) bool)."""
    dirs = _ext.pixel_to_dir(xy=xy, size=size, preset=preset)
    return dirs, ~np.isnan(dirs[..., 0])
