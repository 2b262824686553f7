"""Images in and out: read, write (with the map note) and describe a file."""

from __future__ import annotations

from typing import Any

import os

import numpy as np
import numpy.typing as npt

from . import _spheremap as _ext
from ._args import _ArrayLike, _fields


def read_image(
    path: str | os.PathLike[str], *, linear: bool = False, max_pixels: int | None = None
) -> npt.NDArray[np.float32]:
    """Reads OpenEXR, Radiance HDR, PFM, PNG (8/16-bit), JPEG, WebP, KTX2 or DDS (recognised by
    content) into an (H, W, C) float32 array: linear values, row 0 at the top, C = 1 (Y),
    2 (Y,A), 3 (R,G,B) or 4 (R,G,B,A). LDR files are sRGB-decoded unless `linear` (alpha never
    is). Of a KTX2/DDS texture, level 0 (a cube's as its (6F, F, C) face stack, +X -X +Y -Y +Z
    -Z from the top); read_texture reads every level.

    Raises FileNotFoundError for a missing file and spheremap.DataError for a corrupt one or
    one whose header claims more than `max_pixels` (default 2**28) pixels.
    """

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
    when it wrote it (EXR, PNG, JPEG, HDR, KTX2; a DDS cube reads as its face stack), or None;
    ``texture``: for KTX2 and DDS {"cube": bool, "levels": [(width, height), ...]} (the
    statistics are level 0's), else None. LDR statistics are of the sRGB-decoded values unless
    `linear`.

    Raises FileNotFoundError for a missing file and spheremap.DataError for one spheremap
    cannot read.
    """

    return _ext.info(path=os.fspath(path), request=_fields(locals(), drop=("path",)))


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
    encode: str = "float",
) -> dict[str, int]:
    """Writes an (H, W) or (H, W, C) array (C = 1..4, linear values, row 0 at the top) to
    `path`; the format follows the extension: .exr (float, or `half`), .hdr, .pfm, .png (`bits`
    8 or 16, sRGB-encoded unless `linear`), .jpg, .ktx2 or .dds (one 2D level of RGBA float,
    or `half`; write_texture writes mip levels and cube faces). The file is written atomically.

    half: a value beyond the half-float range (65504), which half would hold as Inf, raises
    spheremap.DataError naming the count and the largest, unless `clamp_half` (clamp to 65504).
    Returns what the format lost: {"clipped": values clipped to the format's range (PNG/JPEG
    [0, 1], HDR no negatives: their light is moved into the texels around them),
    "clamped_half": values clamped with `clamp_half`}.

    mapping, preset, layout, look, up: record what the image is (one of MAPPINGS, its preset,
    for a cube its layout, and the view it was made for) in the file, as the CLI records it in
    the maps it writes (EXR, PNG, JPEG, HDR; not PFM): `info` then reports it and `spheremap
    convert` reads the file without --from.
    """

    note = _ext.map_note(request=_fields(dict(mapping=mapping, preset=preset, layout=layout, look=look, up=up)))
    return _ext.write_image(path=os.fspath(path), array=array, linear=bool(linear), bits=bits, half=bool(half),
                            clamp_half=bool(clamp_half), note=note, encode=encode)


def read_texture(
    path: str | os.PathLike[str], *, max_pixels: int | None = None
) -> tuple[list[npt.NDArray[np.float32]], bool]:
    """Reads a KTX2 or DDS texture (float RGBA/RGB/R, 16- or 32-bit; BC6H, decoded; RGB9E5;
    KTX2 also UASTC HDR 4x4 and ASTC HDR 6x6, transcoded, and Zstandard-supercompressed) with
    all its mip levels -> (levels, cube): level 0 first, each an (H, W, C) float32 array with
    row 0 at the top; for a cube map (cube True) each level is (6, F, F, C): faces +X, -X, +Y, -Y, +Z,
    -Z, each with row 0 at t = 0 of the GL face table, as spheremap.convert returns a cube.

    Raises spheremap.DataError for a file that is not one (other block-compressed formats,
    BasisLZ or zlib supercompression, 3D or array textures are refused with the reason).
    """

    levels, cube = _ext.read_texture(path=os.fspath(path), max_pixels=max_pixels)
    return list(levels), bool(cube)


def write_texture(
    path: str | os.PathLike[str],
    levels: list[_ArrayLike],
    *,
    cube: bool = False,
    half: bool = False,
    clamp_half: bool = False,
    mapping: str | None = None,
    preset: str | None = None,
    look: npt.ArrayLike | None = None,
    up: npt.ArrayLike | None = None,
    encode: str = "float",
    zstd: int | None = None,
) -> list[dict[str, Any]] | None:
    """Writes mip levels (level 0 first; level i is max(1, W >> i) x max(1, H >> i)) as a KTX2
    or DDS texture (by the extension), RGBA float32 or `half`, atomically. With `cube`, each
    level is (6, F, F, C) faces (or their (6F, F, C) stack) in GL order +X, -X, +Y, -Y, +Z, -Z
    and the file holds a cube map. mapping, preset, look, up: recorded in a KTX2 file as write_image records them.

    encode: "float" (RGBA float32 or `half`), "bc6h" (BC6H_UF16 blocks) or "rgb9e5" (shared
    exponent), both RGB in 0..65504 (rgb9e5: 65408), or, KTX2 only, "uastc-hdr-4x4" and
    "astc-hdr-6x6" (Basis Universal's; RGB in 0..65216; writing them needs a build with the
    basisu feature). Values outside the range are clamped with their light moved into the
    texels around them (a warning names the power that still changes); every level is kept
    to its light: blocks that leak are encoded again.
    Their weights are the texel solid angles of the cube's faces or of `mapping`. Returns, for
    an encoding other than float, one dict per level: blocks, repaired, power_error and
    power_error_unrepaired (per channel, decoded / written - 1), rmsle, rmsle_unrepaired,
    clamped, range_loss; else None. zstd: KTX2 Zstandard supercompression level (1-22).
    """

    layout = "vstrip" if cube and mapping is not None else None
    note = _ext.map_note(request=_fields(dict(mapping=mapping, preset=preset, layout=layout, look=look, up=up)))
    return _ext.write_texture(
        path=os.fspath(path),
        levels=list(levels),
        cube=bool(cube),
        half=bool(half),
        clamp_half=bool(clamp_half),
        note=note,
        encode=encode,
        zstd=zstd,
    )
