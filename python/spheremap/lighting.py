"""Lighting from a map: exact MatCaps, spherical-harmonics irradiance, the split-sum DFG table."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from . import _spheremap as _ext
from ._args import _finite, _floats, _name, _seed, _size_any, _vec3
from .convert import _env_array


def _env_request(src: str, src_preset: str | None, src_look, src_up) -> dict[str, Any]:
    """The environment's fields of the core's lighting requests (an array: its NaN/Inf are
    refused by _env_array before)."""
    return {
        "env_format": src,
        "env_preset": src_preset,
        "env_look": _vec3(src_look, "src_look"),
        "env_up": _vec3(src_up, "src_up"),
        "nonfinite": "error",
    }


def bake_matcap(
    env: npt.ArrayLike,
    src: str = "latlong",
    *,
    material: str = "ggx",
    roughness: float = 0.5,
    albedo: npt.ArrayLike | None = None,
    size: int = 256,
    look: npt.ArrayLike | None = None,
    up: npt.ArrayLike | None = None,
    samples: int | None = None,
    max_samples: int = 1024,
    seed: int = 0,
    outside: str = "gutter",
    src_preset: str | None = None,
    src_layout: str | None = None,
    src_look: npt.ArrayLike | None = None,
    src_up: npt.ArrayLike | None = None,
) -> npt.NDArray[np.float32]:
    """A physically exact MatCap of `env` (the engine of ``spheremap bake-matcap``) -> (N, N, C)
    float32, C = 3 (1 for a grey map with a grey albedo).

    The layout is the sphere map's of the view: texel (i, j) has s = (i+1/2)/N,
    t = 1 - (j+1/2)/N, x = 2s - 1, y = 2t - 1 and view-space normal (x, y, sqrt(1 - x^2 - y^2));
    the viewer is orthographic (v = +Z). Each texel is the light the material reflects toward the
    viewer, averaged over its footprint (`samples`, as everywhere; default 4).

    env: (H, W, C) in `src`'s canvas (a cube map as (6, F, F, C) faces or a face stack).
    material: "ggx" (GGX, alpha = roughness^2, height-correlated Smith G2, Fresnel 1) or
        "lambert"; roughness in [0, 1] (0: the mirror, exactly convert(env, src, "sphere")).
    albedo: linear RGB (default 0.8 grey for lambert, white for ggx).
    look, up: the MatCap's view (world directions of the eye's -Z and +Y).
    src_look, src_up: the environment's view when it was made for one.
    """
    _name("mapping", src, "src")
    a = _env_array(_floats(env, "env"), src, "env", src_layout)
    request: dict[str, Any] = {
        "material": _name("material", material, "material"),
        "roughness": _finite(roughness, "roughness"),
        "albedo": _vec3(albedo, "albedo"),
        "size": _size_any(size, "size"),
        "look": _vec3(look, "look"),
        "up": _vec3(up, "up"),
        "samples": 4 if samples is None else _size_any(samples, "samples"),
        "max_samples": _size_any(max_samples, "max_samples"),
        "seed": _seed(seed),
        "outside": _name("outside", outside, "outside"),
        **_env_request(src, src_preset, src_look, src_up),
    }
    return _ext.bake_matcap(image=a, request=request)


def irradiance_sh(
    env: npt.ArrayLike,
    src: str = "latlong",
    *,
    window: float | str | None = None,
    src_preset: str | None = None,
    src_layout: str | None = None,
    src_look: npt.ArrayLike | None = None,
    src_up: npt.ArrayLike | None = None,
) -> dict[str, Any]:
    """Order-2 spherical harmonics of `env` and the irradiance they imply: the report of
    ``spheremap irradiance --json`` as a dict ("coefficients": the 9 radiance coefficients in
    three.js's order and normalization (SphericalHarmonics3 / LightProbe); "filament": "sh",
    pre-scaled for Filament's shader, and "sh_txt"; "irradiance_axes"; "window").

    window: None, "auto" or a size in bands: Filament's deringing window.
    """
    _name("mapping", src, "src")
    a = _env_array(_floats(env, "env"), src, "env", src_layout)
    request = _env_request(src, src_preset, src_look, src_up)
    report: dict[str, Any] = _ext.irradiance_sh(image=a, request=request, window=window)
    return report


def dfg_lut(size: int = 128) -> npt.NDArray[np.float32]:
    """The split-sum DFG table (Karis 2013) of spheremap's GGX -> (N, N, 3) float32: texel (i, j)
    has n.v = (i+1/2)/N and perceptual roughness (j+1/2)/N (row 0 first); channels A, B (the
    directional albedo is F0*A + B) and A + B."""
    return _ext.dfg_lut(size=_size_any(size, "size"))
