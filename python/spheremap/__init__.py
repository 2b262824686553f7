"""spheremap — exact, documented and fast sphere maps.

Conventions (see ``spheremap conventions`` and the README): eye space is right-handed, +Y up,
the viewer looks down -Z. A sphere map's centre (s,t) = (1/2, 1/2) is the direction +Z (back at
the viewer); its whole rim is -Z. Image arrays are (H, W, C) with row 0 at the top = t = 1.
Texel i of n has its centre at (i + 1/2)/n.

Every function takes float32 or float64 arrays (any memory order; Python sequences are read as
float64) and raises ``ValueError`` naming the argument for a wrong shape or dtype.
"""

from __future__ import annotations

import os
from typing import NamedTuple

import numpy as np

from . import _spheremap as _ext
from ._spheremap import DataError, Error, LimitError, UnsupportedError, __version__

__all__ = [
    "__version__",
    "Error",
    "DataError",
    "UnsupportedError",
    "LimitError",
    "Preset",
    "sphere_texgen",
    "dir_to_sphere",
    "sphere_to_dir",
    "reflect",
    "matcap_uv",
    "sphere_texel_solid_angle",
    "dir_to_pixel",
    "pixel_to_dir",
    "presets",
    "read_image",
    "info",
    "write_image",
    "MAPPINGS",
    "dir_to_uv",
    "uv_to_dir",
    "texel_solid_angles",
    "convert",
    "cube_from_layout",
    "cube_to_layout",
    "CUBE_LAYOUTS",
    "FILTERS",
    "TAPS",
    "Scene",
    "generate",
    "NORMALIZE_MODES",
    "SINGULAR_MODES",
    "MATCAP_VARIANTS",
    "LENS_MODELS",
    "PHOTO_FILLS",
    "find_ball",
    "from_mirror_ball",
    "from_fisheye",
    "RENDER_MODES",
    "load_mesh",
    "render",
    "analyze",
]

# The lists of names are the core's (spheremap's Rust crate defines each once).
NORMALIZE_MODES = tuple(_ext.names("normalize"))
SINGULAR_MODES = tuple(_ext.names("singular"))
MATCAP_VARIANTS = tuple(_ext.names("matcap"))
#: Environment mappings (dir_to_uv, uv_to_dir, texel_solid_angles, convert).
MAPPINGS = ("sphere", "latlong", "cube", "angular", "paraboloid", "octahedral")
#: Cube-map file layouts (see the README's diagram); "dice" = "hcross".
CUBE_LAYOUTS = tuple(_ext.names("layout"))
#: Reconstruction filters of convert.
FILTERS = tuple(_ext.names("filter"))
#: How convert's samples read the input's texels.
TAPS = tuple(_ext.names("taps"))
#: Fisheye lens models (from_fisheye; Scene.preview takes the first four).
LENS_MODELS = tuple(_ext.names("lens"))
#: Modes of render.
RENDER_MODES = tuple(_ext.names("render"))
#: What from_mirror_ball / from_fisheye put where no photo sees.
PHOTO_FILLS = tuple(_ext.names("fill"))


def _floats(x, name: str, *, last: tuple[int, ...] | None = None, ndim: int | None = None) -> np.ndarray:
    """float32/float64 C-contiguous view or copy of `x`; ValueError naming `name` otherwise."""
    if isinstance(x, np.ndarray):
        a = x
    else:
        try:
            a = np.asarray(x, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise ValueError(f"{name}: cannot be read as an array of numbers ({e})") from None
    if a.dtype not in (np.float32, np.float64):
        raise ValueError(f"{name}: dtype {a.dtype} is not supported; pass float32 or float64")
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"{name}: expected a {ndim}-D array, got shape {a.shape}")
    if a.ndim == 0:
        raise ValueError(f"{name}: expected an array, got a scalar")
    if last is not None and a.shape[-1] not in last:
        want = " or ".join(str(v) for v in last)
        raise ValueError(f"{name}: last dimension must be {want}, got shape {a.shape}")
    return np.ascontiguousarray(a)


def _stack3(a, a_name: str, b, b_name: str) -> np.ndarray:
    """Two (..., 3) arrays broadcast together and stacked to (..., 6), one common dtype."""
    x = _floats(a, a_name, last=(3,))
    y = _floats(b, b_name, last=(3,))
    if x.dtype != y.dtype:
        x, y = x.astype(np.float64), y.astype(np.float64)
    try:
        x, y = np.broadcast_arrays(x, y)
    except ValueError:
        raise ValueError(f"{b_name}: shape {y.shape} does not broadcast with {a_name} {x.shape}") from None
    return np.concatenate([x, y], axis=-1)


def _name(kind: str, value, arg: str) -> str:
    """`value` checked as a name of `kind` by the core's own parser (aliases included)."""
    if not isinstance(value, str):
        raise ValueError(f"{arg}: expected a name, got {value!r}")
    return _ext.check_name(kind, value, arg)


def _choice(value, name: str, allowed: tuple[str, ...]) -> str:
    if value not in allowed:
        raise ValueError(f"{name}: {value!r} is not one of {', '.join(allowed)}")
    return value


def sphere_texgen(positions, normals, modelview, *, normalize: str = "on", singular: str = "nan",
                  precision: str = "f32", out: np.ndarray | None = None) -> np.ndarray:
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
    pos = _floats(positions, "positions", last=(3, 4), ndim=2)
    nrm = _floats(normals, "normals", last=(3,), ndim=2)
    if nrm.shape[0] != pos.shape[0]:
        raise ValueError(f"normals: expected {pos.shape[0]} rows to match positions, got shape {nrm.shape}")
    mv = _floats(modelview, "modelview", ndim=2)
    if mv.shape != (4, 4):
        raise ValueError(f"modelview: expected shape (4, 4), got {mv.shape}")
    _name("normalize", normalize, "normalize")
    _name("singular", singular, "singular")
    _name("precision", precision, "precision")
    if out is not None and not isinstance(out, np.ndarray):
        raise ValueError("out: expected a numpy array")
    return _ext.sphere_texgen(pos, nrm, mv.astype(np.float64, copy=False), normalize, singular, precision, out)


def dir_to_sphere(dirs, *, singular: str = "nan") -> np.ndarray:
    """Directions (..., 3) (any non-zero length, eye frame) -> sphere-map (s, t) (..., 2).

    The dtype follows the input (float32 runs the float32 path). Zero or non-finite directions
    give NaN; directions parallel to (0,0,-1) (the rim) give NaN or (1/2, 1/2) per `singular`.
    Uses a cancellation-free form of GL's formula near the rim.
    """
    d = _floats(dirs, "dirs", last=(3,))
    return _ext.dir_to_sphere(d, _name("singular", singular, "singular"))


def sphere_to_dir(st) -> tuple[np.ndarray, np.ndarray]:
    """Sphere-map (s, t) (..., 2) -> (unit directions (..., 3), valid (...) bool).

    Outside the disc (and for non-finite input) the direction is NaN and valid is False.
    """
    a = _floats(st, "st", last=(2,))
    dirs = _ext.sphere_to_dir(a)
    return dirs, ~np.isnan(dirs[..., 0])


def reflect(incident, normal) -> np.ndarray:
    """Mirror reflection ``u - 2 (n.u) n`` of incident directions (..., 3) about normals (..., 3)
    (broadcast against each other). Normals are used as given, as GL does."""
    return _ext.reflect(_stack3(incident, "incident", normal, "normal"))


def matcap_uv(normals, positions=None, *, variant: str = "classic", scale: float | None = None) -> np.ndarray:
    """MatCap texture coordinates (..., 2) (v up, like t) for eye-space normals (..., 3).

    variant: "classic" (n.xy/2 + 1/2), "threejs" (MeshMatcapMaterial's view basis, scale 0.495),
        "perspective" (the normal expressed in the frame of its own view ray: see the README).
    positions: eye-space positions (..., 3) of the shaded points, used by "threejs" and
        "perspective"; None means an orthographic view (view ray -Z everywhere).
    scale: radius factor (default 0.5, or 0.495 for "threejs").
    """
    n = _floats(normals, "normals", last=(3,))
    _name("matcap", variant, "variant")
    if positions is None:
        stacked = np.concatenate([n, np.zeros_like(n)], axis=-1)
    else:
        stacked = _stack3(n, "normals", positions, "positions")
    if scale is not None:
        scale = float(scale)
    return _ext.matcap_uv(stacked, positions is not None, variant, scale)


def sphere_texel_solid_angle(size: int) -> np.ndarray:
    """Exact solid angle (sr) of every texel of a size x size sphere map, (size, size) float64.

    Texels wholly inside the disc subtend 16/size**2 sr (the map is equal-area); texels cut by
    the rim get 16 x their area inside the disc; the total is 4 pi.
    """
    size = _size(size, "size")
    return _ext.sphere_texel_solid_angle(size)


def _size(size, name: str) -> int:
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)):
        raise ValueError(f"{name}: expected an integer, got {type(size).__name__}")
    if not 1 <= int(size) <= 1 << 16:
        raise ValueError(f"{name}: must be between 1 and 65536, got {size}")
    return int(size)


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


def dir_to_pixel(dirs, size: int, *, preset: str = "gl", singular: str = "nan") -> np.ndarray:
    """Directions (..., 3) in `preset`'s frame -> continuous pixel coordinates (x, y) (..., 2) in
    that preset's size x size image: (0, 0) is the top-left corner of row 0, pixel centres are at
    i + 1/2. NaN where a direction has no single pixel."""
    d = _floats(dirs, "dirs", last=(3,)).astype(np.float64, copy=False)
    return _ext.dir_to_pixel(d, _size(size, "size"), preset, _name("singular", singular, "singular"))


def pixel_to_dir(xy, size: int, *, preset: str = "gl") -> tuple[np.ndarray, np.ndarray]:
    """Continuous pixel coordinates (..., 2) in `preset`'s size x size image -> (unit directions
    in the preset's frame (..., 3), valid (...) bool)."""
    a = _floats(xy, "xy", last=(2,)).astype(np.float64, copy=False)
    dirs = _ext.pixel_to_dir(a, _size(size, "size"), preset)
    return dirs, ~np.isnan(dirs[..., 0])


def read_image(path, *, linear: bool = False, max_pixels: int | None = None) -> np.ndarray:
    """Reads OpenEXR, Radiance HDR, PFM, PNG (8/16-bit), JPEG or WebP (recognised by content)
    into an (H, W, C) float32 array: linear values, row 0 at the top, C = 1 (Y), 2 (Y,A),
    3 (R,G,B) or 4 (R,G,B,A). LDR files are sRGB-decoded unless `linear` (alpha never is).

    Raises FileNotFoundError for a missing file and spheremap.DataError for a corrupt one or
    one whose header claims more than `max_pixels` (default 2**28) pixels.
    """
    import os

    if max_pixels is not None:
        max_pixels = _size_any(max_pixels, "max_pixels")
    return _ext.read_image(os.fspath(path), bool(linear), max_pixels)


def info(path, *, linear: bool = False) -> dict:
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
    import os

    return _ext.info(os.fspath(path), bool(linear))


def write_image(path, array, *, linear: bool = False, bits: int = 8, half: bool = False,
                clamp_half: bool = False, mapping: str | None = None, preset: str | None = None,
                layout: str | None = None, look=None, up=None) -> dict:
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
    import os

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
        note = _ext.map_note(mapping, preset, layout, _vec3(look, "look"), _vec3(up, "up"))
    elif (preset, layout, look, up) != (None, None, None, None):
        raise ValueError("mapping: preset, layout, look and up describe a mapping; name it")
    if clamp_half and not half:
        raise ValueError("clamp_half: applies to half=True")
    clipped, clamped = _ext.write_image(os.fspath(path), np.ascontiguousarray(a, dtype=np.float32), bool(linear),
                                        bits == 16, bool(half), bool(clamp_half), note)
    return {"clipped": clipped, "clamped_half": clamped}


def _size_any(v, name: str) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
        raise ValueError(f"{name}: expected a positive integer, got {v!r}")
    return int(v)


def dir_to_uv(dirs, mapping: str = "latlong", *, preset: str | None = None) -> np.ndarray:
    """World directions (..., 3) -> image coordinates (u, v) (..., 2) of `mapping` in
    `preset`'s convention: u = x/W to the right, v = y/H DOWN (row 0 at the top), for every
    mapping. mapping "sphere" (presets as `presets()`, default "gl"; u = s, v = 1 - t),
    "latlong" (presets blender (default), threejs, skylibs, filament, mitsuba, pbrt),
    "angular" (Debevec light probe: centre -Z ahead, rim +Z; preset "debevec") or
    "octahedral" (pbrt-v4 equal-area, pbrt's Z-up frame = ours (x, z, y); preset "pbrt").
    NaN where a direction has no single position."""
    d = _floats(dirs, "dirs", last=(3,)).astype(np.float64, copy=False)
    _choice(mapping, "mapping", MAPPINGS)
    return _ext.dir_to_uv(d, mapping, preset)


def uv_to_dir(uv, mapping: str = "latlong", *, preset: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Image coordinates (u, v) (..., 2), v down -> (unit directions (..., 3), valid (...)).
    Lat-long u wraps; points outside a mapping's domain are NaN and invalid."""
    a = _floats(uv, "uv", last=(2,)).astype(np.float64, copy=False)
    _choice(mapping, "mapping", MAPPINGS)
    d = _ext.uv_to_dir(a, mapping, preset)
    return d, ~np.isnan(d[..., 0])


def texel_solid_angles(mapping: str, width: int, height: int | None = None, *, preset: str | None = None) -> np.ndarray:
    """Exact solid angle (sr) of every texel of a height x width canvas of `mapping` (height
    defaults to width/2 for "latlong" and "paraboloid", 6*width for "cube" — the face stack —
    else width); sums to 4 pi (angular and paraboloid: to 1e-7, by quadrature; the others
    exactly)."""
    _choice(mapping, "mapping", MAPPINGS)
    width = _size(width, "width")
    if height is None:
        height = {"latlong": max(1, width // 2), "paraboloid": max(1, width // 2), "cube": 6 * width}.get(mapping, width)
    return _ext.texel_solid_angles(mapping, width, _size(height, "height"), preset)


def _vec3(v, name: str):
    if v is None:
        return None
    a = _floats(v, name, last=(3,), ndim=1).astype(np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: must be finite, got {v!r}")
    return tuple(float(x) for x in a)


def _nonfinite(a: np.ndarray, policy: str, name: str) -> np.ndarray:
    """Applies the NaN/Inf policy ("error", "zero", "keep") to an input array."""
    _name("nonfinite", policy, "nonfinite")
    if policy == "keep":
        return a
    if a.dtype == np.float32 and a.flags.c_contiguous and _ext._all_finite(a):
        return a  # the common case, in one parallel pass (np.isfinite: ~4x slower)
    bad = ~np.isfinite(a)
    if not bad.any():
        return a
    if policy == "zero":
        return np.where(bad, 0, a).astype(a.dtype)
    first = np.unravel_index(int(np.argmax(bad.reshape(-1))), a.shape)
    raise ValueError(f"{name}: {int(bad.sum())} NaN/Inf values (the first at index "
                     f"{tuple(int(i) for i in first)}); pass nonfinite='zero' or 'keep'")


def _seed(v) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
        raise ValueError(f"seed: expected a non-negative integer, got {v!r}")
    return int(v)


def _max_memory(v):
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
        raise ValueError(f"max_memory: expected a positive number of bytes, got {v!r}")
    return int(v)


def convert(image, src: str, dst: str, *, size: int | None = None, samples: int = 4,
            max_samples: int = 1024, filter: str = "box", outside: str = "gutter",
            look=None, up=None, yaw: float | None = None, pitch: float | None = None,
            roll: float | None = None, src_look=None, src_up=None,
            src_preset: str | None = None, dst_preset: str | None = None,
            src_layout: str | None = None,
            seed: int = 0, precision: str = "f32", nonfinite: str = "error",
            max_memory: int | None = None, out: np.ndarray | None = None,
            taps: str = "bilinear") -> np.ndarray:
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
    look, up: the output's view (world vectors of the eye's -Z and +Y), or yaw/pitch/roll in
        degrees; src_look/src_up: the input's view when it was made for one.
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
    _choice(src, "src", MAPPINGS)
    _choice(dst, "dst", MAPPINGS)
    _name("filter", filter, "filter")
    _name("outside", outside, "outside")
    _name("precision", precision, "precision")
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
    max_memory = _max_memory(max_memory)
    if size is not None:
        size = _size_any(size, "size")
    samples = _size_any(samples, "samples")
    max_samples = _size_any(max_samples, "max_samples")
    seed = _seed(seed)
    if look is None and up is not None:
        raise ValueError("up: needs look")
    if look is not None and (yaw, pitch, roll) != (None, None, None):
        raise ValueError("look: give look/up or yaw/pitch/roll, not both")
    ypr = None
    if (yaw, pitch, roll) != (None, None, None):
        ypr = _vec3([yaw or 0.0, pitch or 0.0, roll or 0.0], "yaw")
    if out is not None:
        if not isinstance(out, np.ndarray) or out.dtype != np.float32:
            raise ValueError(f"out: expected a float32 numpy array, got "
                             f"{getattr(out, 'dtype', type(out).__name__)}")
        if not out.flags.c_contiguous or not out.flags.writeable:
            raise ValueError("out: must be C-contiguous and writeable")
        if np.shares_memory(out, a):
            raise ValueError("out: overlaps image")
    res = _ext.convert(np.ascontiguousarray(a, dtype=np.float32), src, dst, size, samples, max_samples,
                       filter, outside, int(seed), precision, src_preset, dst_preset,
                       _vec3(look, "look"), _vec3(up, "up"), ypr, _vec3(src_look, "src_look"),
                       _vec3(src_up, "src_up"), max_memory, out, taps=_name("taps", taps, "taps"))
    if out is None and dst == "cube":  # (an `out` is returned as the caller shaped it)
        f = res.shape[1]
        res = res.reshape(6, f, f, res.shape[2])
    return res


def _cube_layout_of(shape, name: str) -> str:
    """The cube layout an image's shape implies, by the core's rule (cube::Layout::from_shape)."""
    layout, why = _ext.cube_layout_of(int(shape[1]), int(shape[0]))
    if layout is not None:
        return layout
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


def cube_from_layout(image, layout: str) -> np.ndarray:
    """A cube-map image in `layout` (one of CUBE_LAYOUTS) -> (6, F, F, C) faces in GL order and
    GL face orientation (the crosses and "horizon" hold views from inside; see the README)."""
    _name("layout", layout, "layout")
    a = _floats(image, "image")
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or not 1 <= a.shape[2] <= 4:
        raise ValueError(f"image: expected (H, W, C) with C in 1..4, got shape {a.shape}")
    st = _ext.layout_to_stack(np.ascontiguousarray(a, dtype=np.float32), layout)
    f = st.shape[1]
    return st.reshape(6, f, f, st.shape[2])


def cube_to_layout(faces, layout: str = "hcross") -> np.ndarray:
    """(6, F, F, C) faces in GL order -> one image in `layout` (unused cells of a cross are 0)."""
    _name("layout", layout, "layout")
    a = _floats(faces, "faces")
    if a.ndim == 3:
        a = a[..., None]
    if a.ndim != 4 or a.shape[0] != 6 or a.shape[1] != a.shape[2] or not 1 <= a.shape[3] <= 4:
        raise ValueError(f"faces: expected (6, F, F, C) with C in 1..4, got shape {a.shape}")
    st = np.ascontiguousarray(a, dtype=np.float32).reshape(6 * a.shape[1], a.shape[2], a.shape[3])
    return _ext.stack_to_layout(st, layout)


class Scene:
    """A ray-traced scene (OBJ + MTL or glTF 2.0, or built in), usable as `generate`'s fire_ray.

    Calling it, ``scene(origins, directions)``, returns the radiance along each ray: (K, 3)
    float32 for (K, 3) origins and directions. What a ray returns is documented in the README
    ("Ray-traced sphere maps"): emission + diffuse direct light from point and directional lights
    with shadows + environment light + perfect mirrors; shading="emission" returns only the
    emitted colour of the first surface hit (the environment on a miss).
    """

    def __init__(self, _inner):
        self._inner = _inner

    @classmethod
    def load(cls, path, *, background=None, environment=None, environment_mapping: str = "latlong",
             environment_preset: str | None = None, shading: str = "full", max_depth: int = 8,
             indirect_samples: int = 1, seed: int = 0) -> "Scene":
        """Loads an OBJ (+MTL) or glTF/GLB file. background: constant environment colour (RGB,
        default black); environment: an environment map image in `environment_mapping` instead
        (a cube as (6, F, F, C) faces in GL order)."""
        import os
        scene = cls(_ext.Scene.load(os.fspath(path)))
        scene._configure(background, environment, environment_mapping, environment_preset,
                         shading, max_depth, indirect_samples, seed)
        return scene

    @classmethod
    def builtin(cls, name: str = "demo", *, reflectance: float = 0.75, **kwargs) -> "Scene":
        """A built-in scene: "demo" (the demo's little world; view it from (0, 1, 0)),
        "octants" (inside a sphere whose octants glow in 8 colours) or "mirror-ball" (a chrome
        ball of radius 1 at the origin, `reflectance` 0.75 by default, to photograph inside an
        environment). Other keyword arguments as load."""
        _choice(name, "name", ("demo", "octants", "mirror-ball"))
        reflectance = _finite(reflectance, "reflectance")
        if not 0 <= reflectance <= 1:
            raise ValueError(f"reflectance: expected a number in [0, 1], got {reflectance!r}")
        scene = cls(_ext.Scene.builtin(name, reflectance=reflectance))
        if kwargs:
            args = dict(background=None, environment=None, environment_mapping="latlong",
                        environment_preset=None, shading="full", max_depth=8, indirect_samples=1,
                        seed=0)
            unknown = set(kwargs) - set(args)
            if unknown:
                raise TypeError(f"builtin() got unexpected keyword arguments {sorted(unknown)}")
            args.update(kwargs)
            scene._configure(**args)
        return scene

    def _configure(self, background, environment, environment_mapping, environment_preset,
                   shading, max_depth, indirect_samples, seed):
        _choice(shading, "shading", ("full", "emission"))
        if background is not None and environment is not None:
            raise ValueError("environment: give background or environment, not both")
        if background is not None:
            self.set_background(background)
        if environment is not None:
            self.set_environment(environment, environment_mapping, preset=environment_preset)
        for v, n in ((max_depth, "max_depth"), (indirect_samples, "indirect_samples"), (seed, "seed")):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
                raise ValueError(f"{n}: expected a non-negative integer, got {v!r}")
        self._inner.set_options(shading, int(max_depth), int(indirect_samples), int(seed))

    @property
    def triangle_count(self) -> int:
        return self._inner.triangle_count

    @property
    def light_count(self) -> int:
        return self._inner.light_count

    @property
    def bounds(self):
        """((min x, y, z), (max x, y, z)) of the geometry."""
        return self._inner.bounds

    def set_background(self, colour) -> None:
        self._inner.set_background([float(x) for x in _vec3(colour, "background")])

    def set_environment(self, image, mapping: str = "latlong", *, preset: str | None = None) -> None:
        _choice(mapping, "mapping", MAPPINGS)
        a = _floats(image, "environment")
        if mapping == "cube":
            if a.ndim == 3:
                a = a[..., None]
            if a.ndim != 4 or a.shape[0] != 6 or a.shape[1] != a.shape[2]:
                raise ValueError(f"environment: a cube map is (6, F, F, C), got shape {a.shape}")
            a = a.reshape(6 * a.shape[1], a.shape[2], a.shape[3])
        elif a.ndim == 2:
            a = a[:, :, None]
        if a.ndim != 3 or not 1 <= a.shape[2] <= 4:
            raise ValueError(f"environment: expected (H, W, C) with C in 1..4, got shape {a.shape}")
        a = _nonfinite(a, "error", "environment")
        self._inner.set_environment(np.ascontiguousarray(a, dtype=np.float32), mapping, preset)

    def add_point_light(self, position, intensity) -> None:
        self._inner.add_point_light(list(_vec3(position, "position")), list(_vec3(intensity, "intensity")))

    def add_directional_light(self, direction, irradiance) -> None:
        """direction: the way the light travels (e.g. (0, -1, 0) for a sun overhead)."""
        self._inner.add_directional_light(list(_vec3(direction, "direction")),
                                          list(_vec3(irradiance, "irradiance")))

    def _rays(self, origins, directions):
        o = np.ascontiguousarray(_floats(origins, "origins", last=(3,), ndim=2), dtype=np.float32)
        d = np.ascontiguousarray(_floats(directions, "directions", last=(3,), ndim=2), dtype=np.float32)
        if len(o) != len(d):
            raise ValueError(f"origins: {len(o)} rays but directions has {len(d)}")
        return o, d

    def __call__(self, origins, directions) -> np.ndarray:
        """Radiance along each ray: (K, 3) float32."""
        return self._inner.trace(*self._rays(origins, directions))

    def intersect(self, origins, directions) -> np.ndarray:
        """Distance to the closest hit along each ray ((K,) float32, inf on a miss)."""
        return self._inner.intersect(*self._rays(origins, directions))

    def preview(self, eye, target, *, up=(0.0, 1.0, 0.0), fov: float = 40.0, lens: str | None = None,
                size=(640, 480), samples: int = 16, seed: int = 0) -> np.ndarray:
        """What a camera sees of the scene (``spheremap preview``): (H, W, 3) float32, row 0 at
        the top. The camera stands at `eye` looking at `target` with `up`, as gluLookAt.
        fov: horizontal field of view in degrees (perspective); with `lens` (one of LENS_MODELS
        except "polynomial") a fisheye whose image circle fills the shorter side and spans `fov`
        degrees. samples: rays per pixel on a jittered grid (1 = through the pixel centre)."""
        if lens is not None:
            _choice(lens, "lens", LENS_MODELS[:4])
        try:
            w, h = (int(v) for v in size)
        except (TypeError, ValueError):
            raise ValueError(f"size: expected (width, height), got {size!r}") from None
        return _ext.render_camera(self._inner, _vec3(eye, "eye"), _vec3(target, "target"),
                                  _vec3(up, "up"), _finite(fov, "fov"), lens,
                                  _size_any(w, "size"), _size_any(h, "size"),
                                  _size_any(samples, "samples"), _seed(seed))

    def __repr__(self) -> str:
        return f"<spheremap.Scene: {self.triangle_count} triangles, {self.light_count} lights>"


def generate(size: int, fire_ray, *, pos=(0.0, 0.0, 0.0), look=None, up=None, samples: int = 4,
             max_samples: int = 1024, filter: str = "box", outside: str = "gutter", seed: int = 0,
             precision: str = "f32", mapping: str = "sphere", preset: str | None = None,
             max_memory: int | None = None) -> np.ndarray:
    """A sphere map (or any mapping) made by firing rays from `pos` (the classic gen_sphere_map).

    fire_ray: a `Scene` (traced natively, in parallel), or a callable
        ``fire_ray(origins, directions) -> colours`` that receives float32 (K, 3) arrays (one
        batch of rays per output row, K in the thousands; it may be called from several threads
        in turn, holding the GIL) and returns (K,) or (K, C) colours, C = 1..4. It is called once
        first with a single ray to learn C. Its exceptions stop the run and are re-raised.
    size: N (sphere N x N; latlong 2N x N; cube faces N x N, returned as (6, N, N, C)).
    look, up: the view (world vectors of the eye's -Z and +Y; default looking down -Z, +Y up).
    samples: 1 = exactly one ray through each texel centre; S > 1 = at least S rays per texel
        over the filter's footprint, more where the footprint is stretched (the rim), up to
        max_samples. filter: "box" (default), "tent", "gaussian"; outside: "gutter" or "black".
    Deterministic for a seed. Ctrl-C cancels (KeyboardInterrupt). max_memory: refuse
    (spheremap.LimitError) a job needing more bytes (default $SPHEREMAP_MAX_MEMORY or 16 GiB).
    """
    _choice(mapping, "mapping", MAPPINGS)
    _name("filter", filter, "filter")
    _name("outside", outside, "outside")
    _name("precision", precision, "precision")
    size = _size_any(size, "size")
    samples = _size_any(samples, "samples")
    max_samples = _size_any(max_samples, "max_samples")
    seed = _seed(seed)
    if look is None and up is not None:
        raise ValueError("up: needs look")
    p = _vec3(pos, "pos")
    common = (size, mapping, preset, p, _vec3(look, "look"), _vec3(up, "up"), samples, max_samples,
              filter, outside, seed, precision, _max_memory(max_memory))
    if isinstance(fire_ray, Scene):
        out = _ext.generate(fire_ray._inner, 3, *common)
    elif callable(fire_ray):
        def colours(o, d):
            r = np.asarray(fire_ray(o, d), dtype=np.float32)
            if r.ndim == 1:
                r = r[:, None]
            if r.ndim != 2 or r.shape[0] != len(o) or not 1 <= r.shape[1] <= 4:
                raise ValueError(f"fire_ray: returned shape {r.shape} for {len(o)} rays; "
                                 "expected (K,) or (K, C) with C in 1..4")
            return np.ascontiguousarray(r)
        probe = colours(np.asarray([p], np.float32), np.asarray([[0.0, 0.0, 1.0]], np.float32))
        out = _ext.generate(colours, probe.shape[1], *common)
    else:
        raise TypeError(f"fire_ray: expected a spheremap.Scene or a callable, got {type(fire_ray).__name__}")
    if mapping == "cube":
        f = out.shape[1]
        out = out.reshape(6, f, f, out.shape[2])
    return out


def _finite(v, name: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not np.isfinite(v):
        raise ValueError(f"{name}: expected a finite number, got {v!r}")
    return float(v)


def _photo(x, name: str, linear: bool, nonfinite: str):
    """A photo argument: an (H, W[, C]) array, or a path (read; its bytes kept for EXIF).
    Returns (float32 (H, W, C) array, EXIF bytes or None)."""
    if isinstance(x, (str, os.PathLike)):
        try:
            a = read_image(x, linear=linear)
            with open(x, "rb") as f:
                exif = f.read()
        except (OSError, Error) as e:
            raise type(e)(f"{name}: {e}") from None
    else:
        a, exif = _floats(x, name), None
        if a.ndim == 2:
            a = a[:, :, None]
    if a.ndim != 3 or not 1 <= a.shape[2] <= 4:
        raise ValueError(f"{name}: expected (H, W) or (H, W, C) with C in 1..4, got shape {a.shape}")
    a = _nonfinite(a, nonfinite, name)
    return np.ascontiguousarray(a, dtype=np.float32), exif


def _map_out(to, preset, size, samples, max_samples, filter, outside, seed, look, up, fill,
             max_memory) -> dict:
    """The output options shared by the photo routes (the CLI's output flags)."""
    _choice(to, "to", MAPPINGS)
    _name("filter", filter, "filter")
    _name("outside", outside, "outside")
    _name("fill", fill, "fill")
    if look is None and up is not None:
        raise ValueError("up: needs look")
    return dict(to=to, preset=preset, size=_size_any(size, "size"),
                samples=_size_any(samples, "samples"), max_samples=_size_any(max_samples, "max_samples"),
                filter=filter, outside=outside, seed=_seed(seed), look=_vec3(look, "look"),
                up=_vec3(up, "up"), fill=fill, max_memory=_max_memory(max_memory))


def _circle(c, name: str):
    if c is None:
        return None
    a = _floats(c, name, last=(3,), ndim=1)
    if not np.all(np.isfinite(a)) or a[2] <= 0:
        raise ValueError(f"{name}: expected (cx, cy, r) finite with r > 0, got {c!r}")
    return tuple(float(v) for v in a)


def _cube_out(to: str, a: np.ndarray) -> np.ndarray:
    if to == "cube":
        f = a.shape[1]
        return a.reshape(6, f, f, a.shape[2])
    return a


def find_ball(image, *, fov: float | None = None, linear: bool = False) -> dict:
    """Finds a mirror ball in a photo (array or path): its outline to sub-pixel precision.

    fov: the photo's horizontal field of view in degrees. With it, the ball's silhouette cone is
    fitted by the model of the rim (what the pixels around it show: the background, and inside
    it the background's compressed reflection; see the README), and "circle" is the circle
    through the outline's points nearest to and farthest from the image centre (the outline of
    an off-centre ball is an ellipse). Without it, a circle is fitted to edge points.

    Returns {"circle": (cx, cy, r), "fit_rms" (the edge fit's RMS distance in pixels, also as
    "fit_rms_px"; for the rim model the RMS residual of the rim's pixels relative to their
    mean), "fit_points", "confidence" (0 to 1: how much of the rim confirms the fit; with fov a
    ball is found only at 0.5 or more), "reflectance" (the ball's, as the rim model sees it;
    None without fov), "uncertainty_px" (the rim model's estimate of its scatter from the
    photo's noise; None without fov)} in continuous pixel coordinates ((0, 0) the top-left
    corner, pixel centres at i + 1/2). Raises spheremap.DataError when no ball is found with
    confidence ("no mirror ball found ...; pass --circle CX CY R").
    """
    a, _ = _photo(image, "image", linear, "error")
    if fov is not None:
        fov = _finite(fov, "fov")
        if not 0 < fov < 180:
            raise ValueError(f"fov: expected degrees in (0, 180), got {fov!r}")
    cx, cy, r, rms, n, confidence, reflectance, uncertainty = _ext.find_ball(a, fov=fov)
    return {"circle": (cx, cy, r), "fit_rms": rms, "fit_rms_px": rms if fov is None else None, "fit_points": n,
            "confidence": confidence, "reflectance": reflectance, "uncertainty_px": uncertainty}


def from_mirror_ball(image, *, second=None, angle: float = 90.0, align: bool = True,
                     fov: float | None = None, focal: float | None = None, sensor: float | None = None,
                     orthographic: bool = False, circle=None, circle2=None, reflectance=None,
                     camera_radius: float = 20.0, fill: str = "none", size: int = 512,
                     samples: int = 4, max_samples: int = 1024, filter: str = "box",
                     outside: str = "gutter", to: str = "sphere", preset: str | None = None,
                     look=None, up=None, seed: int = 0, linear: bool = False,
                     nonfinite: str = "error", max_memory: int | None = None):
    """A sphere map from one or two photos of a mirror ball (``spheremap from-photo``).

    image, second: the photos, as (H, W[, C]) arrays of linear values or as paths (then read, and
        their EXIF focal length used when no field of view is given). `second` is taken from about
        `angle` degrees around the ball (positive: to the first camera's right); the rotation is
        refined by aligning the photos unless align=False.
    fov: horizontal field of view in degrees (perspective model), or focal + sensor in mm, or the
        photo's EXIF; orthographic=True assumes the classic orthographic camera instead.
    circle, circle2: the ball's outline (cx, cy, r) in continuous pixel coordinates ((0, 0) the
        top-left corner, pixel centres at i + 1/2); default: found (see find_ball).
    reflectance: the ball's reflectance (a number or (r, g, b)); the photo is divided by it.
    camera_radius: degrees around the direction back to the camera given confidence 0.
    fill: "none" (unseen texels 0), "smooth" (pull-push from the seen ones) or "mean".
    The output is the map of a viewer at the (first) camera looking at the ball's centre with the
    camera's up, in mapping `to` (default "sphere", GL convention) of size `size`, each texel
    filtered over its footprint with `samples`..`max_samples` samples; look/up turn it.

    Returns (map (H', W', C) float32 — (6, N, N, C) for to="cube", mask (..., 1) float32 — the
    confidence, 0 where no photo sees, info dict — the fitted circles, distances, unseen cone,
    second shot's rotation, gain and alignment residual, seen fraction).
    """
    if not orthographic and fov is None and focal is None and not isinstance(image, (str, os.PathLike)):
        raise ValueError("fov: the photo's field of view is unknown (an array has no EXIF): give fov, "
                         "focal and sensor, or orthographic=True")
    out = _map_out(to, preset, size, samples, max_samples, filter, outside, seed, look, up, fill,
                   max_memory)
    a, exif = _photo(image, "image", linear, nonfinite)
    b, exif2 = (None, None) if second is None else _photo(second, "second", linear, nonfinite)
    if reflectance is None:
        refl = (1.0, 1.0, 1.0)
    else:
        try:
            r = np.atleast_1d(np.asarray(reflectance, dtype=np.float64))
        except (TypeError, ValueError):
            raise ValueError(f"reflectance: expected one positive number or three, got {reflectance!r}") from None
        if r.ndim != 1 or len(r) not in (1, 3) or not np.all((r > 0) & np.isfinite(r)):
            raise ValueError(f"reflectance: expected one positive number or three, got {reflectance!r}")
        refl = tuple(float(v) for v in np.broadcast_to(r, 3))
    fov = None if fov is None else _finite(fov, "fov")
    focal = None if focal is None else _finite(focal, "focal")
    sensor = None if sensor is None else _finite(sensor, "sensor")
    m, mask, info = _ext.from_mirror_ball(
        a, exif, b, exif2, bool(orthographic), fov, focal, sensor, _circle(circle, "circle"),
        _circle(circle2, "circle2"), _finite(angle, "angle"), bool(align), refl,
        _finite(camera_radius, "camera_radius"), out)
    return _cube_out(to, m), _cube_out(to, mask), info


def from_fisheye(image, *, model: str, fov: float, centre=None, radius: float | None = None, k=None,
                 fill: str = "none", size: int = 512, samples: int = 4, max_samples: int = 1024,
                 filter: str = "box", outside: str = "gutter", to: str = "sphere",
                 preset: str | None = None, look=None, up=None, seed: int = 0, linear: bool = False,
                 nonfinite: str = "error", max_memory: int | None = None):
    """A sphere map of the camera's view from a fisheye photo (``spheremap from-fisheye``).

    model: one of LENS_MODELS; fov: the field of view in degrees across the image circle;
    centre: the optical centre (cx, cy) in continuous pixel coordinates (default the image
    centre); radius: the image circle's radius in pixels (default half the shorter side);
    k: (k1, k2, k3, k4) of the polynomial model r/f = θ(1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸).
    Other arguments and the result as from_mirror_ball; the mask is the covered fraction of each
    texel (0 for the directions the lens did not see).
    """
    _choice(model, "model", LENS_MODELS)
    if k is not None and model != "polynomial":
        raise ValueError("k: only the polynomial model takes coefficients")
    kk = (0.0, 0.0, 0.0, 0.0)
    if k is not None:
        ka = _floats(k, "k", last=(4,), ndim=1)
        if not np.all(np.isfinite(ka)):
            raise ValueError(f"k: must be finite, got {k!r}")
        kk = tuple(float(v) for v in ka)
    c = None
    if centre is not None:
        ca = _floats(centre, "centre", last=(2,), ndim=1)
        if not np.all(np.isfinite(ca)):
            raise ValueError(f"centre: must be finite, got {centre!r}")
        c = (float(ca[0]), float(ca[1]))
    out = _map_out(to, preset, size, samples, max_samples, filter, outside, seed, look, up, fill,
                   max_memory)
    a, _ = _photo(image, "image", linear, nonfinite)
    m, mask, info = _ext.from_fisheye(a, model, kk, _finite(fov, "fov"), c,
                                      None if radius is None else _finite(radius, "radius"), out)
    return _cube_out(to, m), _cube_out(to, mask), info


def load_mesh(path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reads an OBJ or glTF/GLB mesh -> (positions (N, 3) float32, normals (N, 3) float32,
    triangles (M, 3) uint32): faces triangulated, glTF node transforms applied, the file's
    vertex normals or else angle-weighted ones (see the README)."""
    return _ext.load_mesh(os.fspath(path))


def _mesh_arrays(mesh):
    """A mesh argument (a path, or (positions, normals or None, triangles)) as the arrays the
    extension takes."""
    if isinstance(mesh, (str, os.PathLike)):
        return load_mesh(mesh)
    try:
        p, n, t = mesh
    except (TypeError, ValueError):
        raise ValueError("mesh: expected a path or (positions, normals, triangles)") from None
    p = np.ascontiguousarray(_floats(p, "positions", last=(3,), ndim=2), dtype=np.float32)
    if n is not None:
        n = np.ascontiguousarray(_floats(n, "normals", last=(3,), ndim=2), dtype=np.float32)
    t = np.asarray(t)
    if t.ndim != 2 or t.shape[1] != 3 or not np.issubdtype(t.dtype, np.integer) or (t.size and t.min() < 0):
        raise ValueError(f"triangles: expected (M, 3) non-negative integers, got {t.dtype} {t.shape}")
    return p, n, np.ascontiguousarray(t, dtype=np.uint32)


def _env_image(env, env_format: str, linear: bool, layout: str | None = None) -> np.ndarray:
    if isinstance(env, (str, os.PathLike)):
        a = read_image(env, linear=linear)
    else:
        a = _floats(env, "env")
    if env_format == "cube":
        if layout is not None or (a.ndim == 3 and a.shape[1] * 6 != a.shape[0]):
            a = _cube_faces(a, layout, "env")
        if a.ndim == 4:
            if a.shape[0] != 6 or a.shape[1] != a.shape[2]:
                raise ValueError(f"env: a cube map is (6, F, F, C), got shape {a.shape}")
            a = a.reshape(6 * a.shape[1], a.shape[2], a.shape[3])
    elif a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or not 1 <= a.shape[2] <= 4:
        raise ValueError(f"env: expected (H, W) or (H, W, C) with C in 1..4, got shape {a.shape}")
    a = _nonfinite(a, "error", "env")
    return np.ascontiguousarray(a, dtype=np.float32)


def render(mesh, env=None, *, mode: str = "per-pixel", env_format: str | None = None,
           env_preset: str | None = None, matcap_variant: str = "classic", eye=None, target=None,
           up=None, fovy: float = 40.0, near: float | None = None, far: float | None = None,
           size=(512, 512), background=(0.0, 0.0, 0.0), aa: int = 1, wrap: str = "clamp-to-edge",
           linear: bool = False, env_layout: str | None = None) -> np.ndarray:
    """Draws a mesh with the CPU rasterizer (``spheremap render``; see the README).

    mesh: a path (OBJ, glTF/GLB) or (positions (N, 3), normals (N, 3) or None, triangles (M, 3)).
    env: the sphere map (per-vertex, per-pixel), MatCap image (matcap) or environment map in
        `env_format` (per-pixel), as an array or a path; not needed for normals and error. A
        cube map is (6, F, F, C) faces or one image in a layout (`env_layout`, one of
        CUBE_LAYOUTS, or implied by its shape as in `convert`). env_format, env_preset and
        env_layout default, for a path, to what spheremap noted in the file when it wrote it
        (as the CLI's --env-format does), else to "sphere". A sphere map in another preset than
        "gl" is resampled into the GL sphere map texgen addresses first.
    mode: one of RENDER_MODES. per-vertex is OpenGL's fixed-function GL_SPHERE_MAP path
        (texgen per vertex, (s, t) interpolated, GL_LINEAR); per-pixel the reflection vector per
        pixel (a sphere map in eye space, other mappings in world space).
    eye, target, up, fovy, near, far: gluLookAt + gluPerspective (defaults frame the mesh).
    size: (width, height). aa: k x k samples per pixel. wrap: "clamp-to-edge" or "repeat".

    Returns linear float32 (H, W, 3), row 0 at the top; for mode="error" (H, W, 2): the angle
    in degrees between the per-vertex and per-pixel lookup directions, and the coverage.
    """
    _choice(mode, "mode", RENDER_MODES)
    if env_format is not None:
        _choice(env_format, "env_format", MAPPINGS)
    if isinstance(env, (str, os.PathLike)):
        env_format, env_preset, noted_layout = _ext.mapping_for(os.fspath(env), env_format, env_preset, "sphere")
        env_layout = env_layout if env_layout is not None else noted_layout
    elif env_format is None:
        env_format = "sphere"
    _choice(matcap_variant, "matcap_variant", MATCAP_VARIANTS)
    _choice(wrap, "wrap", ("clamp-to-edge", "repeat"))
    p, n, t = _mesh_arrays(mesh)
    if mode in ("per-vertex", "matcap") and env_format != "sphere":
        raise ValueError(f"env_format: mode {mode!r} looks up (s, t) in a sphere map or MatCap image; "
                         "convert the map to a sphere map first")
    if env is None and mode not in ("normals", "error"):
        raise ValueError(f"env: mode {mode!r} needs an environment map")
    if env_layout is not None and env_format != "cube":
        raise ValueError(f"env_layout: only for env_format='cube', not {env_format!r}")
    e = None if env is None else _env_image(env, env_format, linear, env_layout)
    try:
        w, h = (int(v) for v in size)
    except (TypeError, ValueError):
        raise ValueError(f"size: expected (width, height), got {size!r}") from None
    bg = _vec3(background, "background")
    return _ext.render(p, n, t, e, env_format, env_preset, mode, matcap_variant, _vec3(eye, "eye"),
                       _vec3(target, "target"), _vec3(up, "up"), _finite(fovy, "fovy"),
                       None if near is None else _finite(near, "near"),
                       None if far is None else _finite(far, "far"), _size_any(w, "size"),
                       _size_any(h, "size"), tuple(float(v) for v in bg), _size_any(aa, "aa"), wrap)


def _stats(a: np.ndarray) -> dict:
    f = a[np.isfinite(a)]
    if f.size == 0:
        return {"min": float("nan"), "max": float("nan"), "mean": float("nan"), "count": 0}
    return {"min": float(f.min()), "max": float(f.max()), "mean": float(f.mean()), "count": int(f.size)}


def analyze(map=None, *, mapping: str = "sphere", preset: str | None = None, size: int = 256,
            mesh=None, eye=None, target=None, up=None, fovy: float = 40.0, near: float | None = None,
            far: float | None = None, view_size=(512, 512), threshold: float = 1.0) -> dict:
    """Sampling analytics (``spheremap analyze``; definitions in the README).

    map: an environment map (array or path) whose canvas is analysed as `mapping`; without it,
        the `mapping` canvas of `size` N (1 to 8192).
    Returns a dict: "solid_angle" (sr), "anisotropy", "resolution_deg" (the coarsest angular
    step per texel), each (H, W) float64 with NaN off the map, and "stats" (min/max/mean of
    each). With `mesh` (a path or (positions, normals or None, triangles)) and a camera as
    render: "mesh" = {"triangle_error_deg" (M,), "in_view" (M,), "split" (M,) (the advised
    split per triangle: edges in k, k*k pieces; max_split + 1 = cannot get under the
    threshold), "over" (indices of triangles in view over `threshold` degrees),
    "uniform_split", "triangles_after_adaptive", "unfixable", "pixel_error_deg" ((H, W), NaN
    where no surface)}.
    """
    _choice(mapping, "mapping", MAPPINGS)
    if map is not None:
        a = read_image(map) if isinstance(map, (str, os.PathLike)) else _floats(map, "map")
        if mapping == "cube" and a.ndim == 4:
            h, w = 6 * a.shape[1], a.shape[2]
        elif a.ndim in (2, 3):
            h, w = a.shape[:2]
        else:
            raise ValueError(f"map: expected an image (H, W[, C]), got shape {a.shape}")
    else:
        w = h = None
    sa, an, res = _ext.analyze_mapping(mapping, preset, width=w, height=h,
                                       size=None if map is not None else _size_any(size, "size"))
    h, w = sa.shape
    out = {"mapping": mapping, "width": w, "height": h, "solid_angle": sa, "anisotropy": an,
           "resolution_deg": res,
           "stats": {"solid_angle": _stats(sa), "anisotropy": _stats(an), "resolution_deg": _stats(res)}}
    if mesh is not None:
        p, nrm, t = _mesh_arrays(mesh)
        try:
            vw, vh = (int(v) for v in view_size)
        except (TypeError, ValueError):
            raise ValueError(f"view_size: expected (width, height), got {view_size!r}") from None
        cam = (_vec3(eye, "eye"), _vec3(target, "target"), _vec3(up, "up"), _finite(fovy, "fovy"),
               None if near is None else _finite(near, "near"), None if far is None else _finite(far, "far"),
               _size_any(vw, "view_size"), _size_any(vh, "view_size"))
        err, in_view, split, k, after, unfixable = _ext.analyze_mesh(p, nrm, t, *cam, _finite(threshold, "threshold"))
        heat = render((p, nrm, t), mode="error", eye=eye, target=target, up=up, fovy=fovy, near=near,
                      far=far, size=(vw, vh), aa=2)
        px = np.where(heat[..., 1] > 0, heat[..., 0], np.nan)
        out["mesh"] = {"triangle_error_deg": err, "in_view": in_view, "split": split,
                       "over": np.nonzero(in_view & (err > threshold))[0], "uniform_split": int(k),
                       "triangles_after_adaptive": int(after), "unfixable": int(unfixable),
                       "max_split": _ext.MAX_SPLIT, "pixel_error_deg": px}
    return out
