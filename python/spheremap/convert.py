"""Conversions between mappings, and cube maps in file layouts."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from . import _spheremap as _ext
from ._args import _fields, _source_aliases


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
    # The core's conversion request (spheremap::jobs::convert::ConvertJob) checks every field.
    job = _fields(locals(), drop=("image", "out"))
    job["to"], job["preset"] = job.pop("dst"), job.pop("dst_preset", None)
    return _ext.convert(image=image, job=job, out=out)


def cube_from_layout(image: npt.ArrayLike, layout: str) -> npt.NDArray[np.float32]:
    """A cube-map image in `layout` (one of CUBE_LAYOUTS) -> (6, F, F, C) faces in GL order and
    GL face orientation (the crosses and "horizon" hold views from inside; see the README)."""
    return _ext.env_array(image=image, cube=True, layout=layout, name="image")


def cube_to_layout(faces: npt.ArrayLike, layout: str = "hcross") -> npt.NDArray[np.float32]:
    """(6, F, F, C) faces in GL order -> one image in `layout` (unused cells of a cross are 0)."""
    return _ext.stack_to_layout(faces=faces, layout=layout)
