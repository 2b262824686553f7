"""Conversions between mappings, and cube maps in file layouts."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from . import _spheremap as _ext
from ._args import _fields, _floats, _name, _nonfinite, _source_aliases


@_source_aliases
def convert(
    image: npt.ArrayLike,
    src: str,
    dst: str,
    *,
    size: int | None = None,
    samples: int = 4,
    max_samples: int = 1024,
    filter: str = "box",
    outside: str = "gutter",
    look: npt.ArrayLike | None = None,
    up: npt.ArrayLike | None = None,
    yaw: float | None = None,
    pitch: float | None = None,
    roll: float | None = None,
    src_look: npt.ArrayLike | None = None,
    src_up: npt.ArrayLike | None = None,
    src_preset: str | None = None,
    dst_preset: str | None = None,
    src_layout: str | None = None,
    seed: int = 0,
    precision: str = "f32",
    nonfinite: str = "error",
    max_memory: int | None = None,
    out: npt.NDArray[np.float32] | None = None,
    taps: str = "bilinear",
    conserve: bool = True,
) -> npt.NDArray[np.float32]:
    """Converts an environment map between mappings (the engine of ``spheremap convert``).

    image: (H, W, C) float32/float64, C = 1..4 (an (H, W) array is one channel), in `src`'s
        canvas; for src="cube" a (6, F, F, C) array of faces in GL order +X, -X, +Y, -Y, +Z, -Z
        (GL/KTX face orientation), or one image in a layout: `src_layout` (one of CUBE_LAYOUTS)
        names it, else its shape does as the CLI's does (1:6 vstrip, 4:3 hcross, 3:4 vcross; a
        6:1 image is hstrip or horizon and must be named).
    src, dst: one of MAPPINGS; src_preset / dst_preset name their conventions (see the README).
    size: N of the output (sphere N x N, latlong 2N x N, cube faces N x N, ...); default from
        the input.
    samples: 1 = exactly one bilinear lookup at each texel centre (no filtering); S > 1 = at
        least S stratified samples per texel over the filter's footprint, more where the
        footprint covers more source texels (up to max_samples).
    filter: "box" (the texel's own footprint, default), "tent", "gaussian".
    taps: how each sample reads the input's texels: "bilinear" (2x2, default) or "bicubic"
        (4x4 Catmull-Rom, clamped to the nearest 2x2's range; sharper where output texels are
        as small as the input's or smaller; slower).
    outside: "gutter" (mirror across a disc's rim, default) or "black".
    conserve: keep the light (default, with samples > 1): the input's brightest texels (a sun,
        a softbox) are integrated exactly over the output's texels and the sampled part
        normalized, so the output's power (sum of L times texel solid angle) is the input's;
        False leaves the sampled filter alone.
    look, up: the output's view (world vectors of the eye's -Z and +Y), or yaw/pitch/roll in
        degrees; src_look/src_up: the input's view when it was made for one.
    The source's keywords (src, src_preset, src_layout, src_look, src_up) are also taken in the
    older spellings of recipes, from / from_preset / … and env_format / env_preset / …
    (SOURCE_ALIASES).
    precision: "f32" (fast) or "f64" (reference).
    nonfinite: NaN/Inf in `image`: "error" (ValueError naming the count and the first
        location), "zero" (replaced by 0) or "keep".
    max_memory: refuse (spheremap.LimitError) a job needing more bytes (default
        $SPHEREMAP_MAX_MEMORY or 16 GiB).

    out: an array to write the result into and return (float32, C-contiguous, writeable, of
        the result's shape; not overlapping `image`). Reusing one saves the first touch of a
        fresh result (page faults: 2-3 ms for a 1024^2 RGB sphere map). On an error or
        Ctrl-C its contents are unspecified.

    Returns float32 (H', W', C), or (6, N, N, C) for dst="cube". Ctrl-C cancels.
    """
    job = _fields(locals(), drop=("image", "out", "src_layout", "nonfinite"))
    job["to"], job["preset"] = job.pop("dst"), job.pop("dst_preset", None)
    a = _floats(image, "image")
    if src_layout is not None and src != "cube":
        raise ValueError(f"src_layout: only for src='cube', not {src!r}")
    if src == "cube":
        a = _cube_faces(a, src_layout, "image")
        if a.ndim != 4 or a.shape[0] != 6 or a.shape[1] != a.shape[2] or not 1 <= a.shape[3] <= 4:
            raise ValueError(f"image: a cube map is (6, F, F, C) with C in 1..4, got shape {a.shape}")
        a = a.reshape(6 * a.shape[1], a.shape[2], a.shape[3])
    else:
        if a.ndim == 2:
            a = a[:, :, None]
        if a.ndim != 3 or not 1 <= a.shape[2] <= 4:
            raise ValueError(f"image: expected (H, W) or (H, W, C) with C in 1..4, got shape {a.shape}")
    a = _nonfinite(a, nonfinite, "image")
    if out is not None and np.shares_memory(out, a):
        raise ValueError("out: overlaps image")
    # The core's conversion request (spheremap::jobs::convert::ConvertJob) checks every field.
    res = _ext.convert(image=np.ascontiguousarray(a, dtype=np.float32), job=job, out=out)
    if out is None and dst == "cube":  # (an `out` is returned as the caller shaped it)
        f = res.shape[1]
        res = res.reshape(6, f, f, res.shape[2])
    return res


def _cube_layout_of(shape, name: str) -> str:
    """The cube layout an image's shape implies, by the core's rule (images::cube_layout::Layout::from_shape)."""
    layout, why = _ext.cube_layout_of(width=int(shape[1]), height=int(shape[0]))
    if layout is not None:
        return layout
    why = why or "its shape is no layout's"
    if "could be" in why:  # 6:1: hstrip or horizon
        raise ValueError(f"{name}: {why}")
    raise ValueError(f"{name}: a cube map is (6, F, F, C) faces or one image in a layout, and {why}")


def _cube_faces(a: np.ndarray, layout: str | None, name: str) -> np.ndarray:
    """A cube map given as faces or as one image in a layout -> (6, F, F, C) (or the array
    unchanged when it is neither, for the caller's shape error)."""
    if layout is not None:
        _name("layout", layout, f"{name} layout")
        if a.ndim not in (2, 3):
            raise ValueError(f"{name}: a cube map in a layout is (H, W) or (H, W, C), got shape {a.shape}")
        return cube_from_layout(a, layout)
    if a.ndim == 3 and a.shape[0] == 6 and a.shape[1] == a.shape[2]:
        return a[..., None]  # six one-channel faces
    if a.ndim == 2 or (a.ndim == 3 and 1 <= a.shape[2] <= 4):
        return cube_from_layout(a, _cube_layout_of(a.shape, name))
    return a


def _env_array(a: np.ndarray, mapping: str, name: str, layout: str | None = None) -> np.ndarray:
    """An environment map array as the native side takes it: (H, W, C) float32, C-contiguous,
    a cube map as its face stack (6F, F, C) — given as faces (6, F, F[, C]), a stack, or one
    image in a layout — and no NaN/Inf (errors name `name`)."""
    if mapping == "cube":
        if layout is not None or (a.ndim == 3 and a.shape[1] * 6 != a.shape[0]):
            a = _cube_faces(a, layout, name)
        if a.ndim == 4:
            if a.shape[0] != 6 or a.shape[1] != a.shape[2]:
                raise ValueError(f"{name}: a cube map is (6, F, F, C), got shape {a.shape}")
            a = a.reshape(6 * a.shape[1], a.shape[2], a.shape[3])
    elif a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or not 1 <= a.shape[2] <= 4:
        raise ValueError(f"{name}: expected (H, W) or (H, W, C) with C in 1..4, got shape {a.shape}")
    a = _nonfinite(a, "error", name)
    return np.ascontiguousarray(a, dtype=np.float32)


def cube_from_layout(image: npt.ArrayLike, layout: str) -> npt.NDArray[np.float32]:
    """A cube-map image in `layout` (one of CUBE_LAYOUTS) -> (6, F, F, C) faces in GL order and
    GL face orientation (the crosses and "horizon" hold views from inside; see the README)."""
    _name("layout", layout, "layout")
    a = _floats(image, "image")
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or not 1 <= a.shape[2] <= 4:
        raise ValueError(f"image: expected (H, W, C) with C in 1..4, got shape {a.shape}")
    st = _ext.layout_to_stack(image=np.ascontiguousarray(a, dtype=np.float32), layout=layout)
    f = st.shape[1]
    return st.reshape(6, f, f, st.shape[2])


def cube_to_layout(faces: npt.ArrayLike, layout: str = "hcross") -> npt.NDArray[np.float32]:
    """(6, F, F, C) faces in GL order -> one image in `layout` (unused cells of a cross are 0)."""
    _name("layout", layout, "layout")
    a = _floats(faces, "faces")
    if a.ndim == 3:
        a = a[..., None]
    if a.ndim != 4 or a.shape[0] != 6 or a.shape[1] != a.shape[2] or not 1 <= a.shape[3] <= 4:
        raise ValueError(f"faces: expected (6, F, F, C) with C in 1..4, got shape {a.shape}")
    st = np.ascontiguousarray(a, dtype=np.float32).reshape(6 * a.shape[1], a.shape[2], a.shape[3])
    return _ext.stack_to_layout(stack=st, layout=layout)
