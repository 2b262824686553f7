"""Images in and out: read, write (with the map note) and describe a file."""

from __future__ import annotations

from typing import Any

import os

import numpy as np
import numpy.typing as npt

from . import _spheremap as _ext
from ._args import _ArrayLike, _choice, _floats, _size_any, _vec3
from .names import MAPPINGS


def read_image(
    path: str | os.PathLike[str], *, linear: bool = False, max_pixels: int | None = None
) -> npt.NDArray[np.float32]:
    """Reads OpenEXR, Radiance HDR, PFM, PNG (8/16-bit), JPEG or WebP (recognised by content)
    into an (H, W, C) float32 array: linear values, row 0 at the top, C = 1 (Y), 2 (Y,A),
    3 (R,G,B) or 4 (R,G,B,A). LDR files are sRGB-decoded unless `linear` (alpha never is).

    Raises FileNotFoundError for a missing file and spheremap.DataError for a corrupt one or
    one whose header claims more than `max_pixels` (default 2**28) pixels.
    """

    if max_pixels is not None:
        max_pixels = _size_any(max_pixels, "max_pixels")
    return _ext.read_image(path=os.fspath(path), linear=bool(linear), max_pixels=max_pixels)


def info(path: str | os.PathLike[str], *, linear: bool = False) -> dict[str, Any]:
    """Describes an image file, as `spheremap info --json` does: ``format`` (recognised by
    content; ``extension_names`` is the other format its extension names, if it disagrees),
    ``width``, ``height``, ``channels``, per-channel ``stats`` (min/max/mean over finite values,
    None where there are none), ``nan``, ``inf``, ``negative``, ``first_non_finite`` ((x, y) or
    None) and ``mapping_guess`` (``name``, ``reason``, ``is_a_guess``: True — from the shape and,
    for a square image, whether its corners are empty or mirror the disc, never read from the
    file) and ``recorded``: the ``mapping``, ``preset``, cube ``layout`` or ``face``, and the
    view's ``look`` and ``up`` (None for the identity view) that spheremap noted in the file
    when it wrote it (EXR, PNG, JPEG, HDR), or None. LDR statistics
    are of the sRGB-decoded values unless `linear`.

    Raises FileNotFoundError for a missing file and spheremap.DataError for one spheremap
    cannot read.
    """

    return _ext.info(path=os.fspath(path), linear=bool(linear))


def write_image(
    path: str | os.PathLike[str],
    array: _ArrayLike,
    *,
    linear: bool = False,
    bits: int = 8,
    half: bool = False,
    clamp_half: bool = False,
    mapping: str | None = None,
    preset: str | None = None,
    layout: str | None = None,
    look: npt.ArrayLike | None = None,
    up: npt.ArrayLike | None = None,
) -> dict[str, int]:
    """Writes an (H, W) or (H, W, C) array (C = 1..4, linear values, row 0 at the top) to
    `path`; the format follows the extension: .exr (float, or `half`), .hdr, .pfm, .png (`bits`
    8 or 16, sRGB-encoded unless `linear`), .jpg. The file is written atomically.

    half: a value beyond the half-float range (65504), which half would hold as Inf, raises
    spheremap.DataError naming the count and the largest, unless `clamp_half` (clamp to 65504).
    Returns what the format lost: {"clipped": values clipped to the format's range (PNG/JPEG
    [0, 1], HDR no negatives), "clamped_half": values clamped with `clamp_half`}.

    mapping, preset, layout, look, up: record what the image is (one of MAPPINGS, its preset,
    for a cube its layout, and the view it was made for) in the file, as the CLI records it in
    the maps it writes (EXR, PNG, JPEG, HDR; not PFM): `info` then reports it and `spheremap
    convert` reads the file without --from.
    """

    a = _floats(array, "array")
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or not 1 <= a.shape[2] <= 4 or a.shape[0] == 0 or a.shape[1] == 0:
        raise ValueError(f"array: expected (H, W) or (H, W, C) with C in 1..4, got shape {a.shape}")
    if bits not in (8, 16):
        raise ValueError(f"bits: must be 8 or 16, got {bits!r}")
    note = None
    if mapping is not None:
        _choice(mapping, "mapping", MAPPINGS)
        note = _ext.map_note(
            mapping=mapping, preset=preset, layout=layout, look=_vec3(look, "look"), up=_vec3(up, "up")
        )
    elif (preset, layout, look, up) != (None, None, None, None):
        raise ValueError("mapping: preset, layout, look and up describe a mapping; name it")
    if clamp_half and not half:
        raise ValueError("clamp_half: applies to half=True")
    clipped, clamped = _ext.write_image(
        path=os.fspath(path),
        array=np.ascontiguousarray(a, dtype=np.float32),
        linear=bool(linear),
        png16=bits == 16,
        half=bool(half),
        clamp_half=bool(clamp_half),
        note=note,
    )
    return {"clipped": clipped, "clamped_half": clamped}
