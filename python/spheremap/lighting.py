"""Lighting from a map: exact MatCaps, prefiltered radiance and irradiance, spherical-harmonics
irradiance, the split-sum DFG table."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from . import _spheremap as _ext
from ._args import _fields, _source_aliases


@_source_aliases
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
    return _ext.bake_matcap(image=env, request=_fields(locals(), drop=("env",)))


@_source_aliases
def prefilter(
    env: npt.ArrayLike,
    src: str = "latlong",
    *,
    to: str = "cube",
    levels: int | None = None,
    size: int | None = None,
    samples: int | None = None,
    irradiance: bool = False,
    roughness_map: str = "filament",
    preset: str | None = None,
    look: npt.ArrayLike | None = None,
    up: npt.ArrayLike | None = None,
    max_samples: int = 1024,
    seed: int = 0,
    outside: str = "gutter",
    tolerance: float | None = None,
    method: str = "tree",
    lobe_samples: int = 1024,
    src_preset: str | None = None,
    src_layout: str | None = None,
    src_look: npt.ArrayLike | None = None,
    src_up: npt.ArrayLike | None = None,
    report: bool = False,
) -> Any:
    """Prefiltered lighting of `env` (the engine of ``spheremap prefilter``) -> a list of levels,
    level 0 first, each an (H, W, C) float32 array in `to`'s canvas (a cube's as (6, F, F, C)
    faces in GL order, as convert returns them); with `report`, (levels, reports), one dict per
    level ("roughness", "method", "integrals", "children", "light", "seconds", ...).

    Level i of L has size N >> i (N = `size`, default 256; cube faces N x N, latlong 2N x N) and
    perceptual roughness r_i from `roughness_map`: "filament" (r(2 - r) = i/(L - 1); three.js
    from r187 too), "threejs" (three.js up to r186: the roughness its cube-UV PMREM shader reads
    from a face of that size) or "linear"; levels
    default down to 8 texels. For every mapping but "sphere" a texel in direction r holds the
    split-sum prefiltered radiance, the integral of L(l) D(h) (r.l) over that of D(h) (r.l)
    (n = v = r; a constant map gives itself). For "sphere" each level is the exact GGX MatCap
    of albedo 1 of the view (`look`, `up`), with no n = v assumption.

    irradiance: one level (default size 32) of (1/pi) times the irradiance: the radiance a white
    Lambertian surface reflects.
    samples: spatial samples per texel (default 1, the centre; more average its footprint). A
        texel wider than its level's lobe holds the lobe's mean over its footprint whatever
        `samples` says: the lobes are evaluated on a finer canvas and averaged by solid angle.
    tolerance: the error each integral may leave, relative to the map's mean radiance (default
    1e-4; 1e-5 is three times slower, 1e-3 three times faster).
    method: "tree" (exact integrals, the default) or "sampled" (filtered importance sampling
    from a cube mip pyramid with `lobe_samples` GGX samples per texel, as Filament's cmgen:
    fast, approximate).
    """
    arrays, reports = _ext.prefilter(image=env, request=_fields(locals(), drop=("env", "report")))
    if report:
        return list(arrays), list(reports)
    return list(arrays)


@_source_aliases
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
    report: dict[str, Any] = _ext.irradiance_sh(image=env, request=_fields(locals(), drop=("env",)))
    return report


def dfg_lut(size: int = 128) -> npt.NDArray[np.float32]:
    """The split-sum DFG table (Karis 2013) of spheremap's GGX -> (N, N, 3) float32: texel (i, j)
    has n.v = (i+1/2)/N and perceptual roughness (j+1/2)/N (row 0 first); channels A, B (the
    directional albedo is F0*A + B) and A + B."""
    return _ext.dfg_lut(request=_fields(locals()))
