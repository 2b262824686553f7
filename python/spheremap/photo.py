"""Maps from photos: mirror balls (one or two shots) and fisheye lenses."""

from __future__ import annotations

from typing import Any

import os

import numpy as np
import numpy.typing as npt

from . import _spheremap as _ext
from ._spheremap import Error
from ._args import (
    _Photo,
    _PhotoResult,
    _finite,
    _floats,
    _max_memory,
    _name,
    _nonfinite,
    _seed,
    _size_any,
    _vec3,
)
from .images import read_image


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


def _map_out(
    to, preset, size, samples, max_samples, filter, outside, seed, look, up, fill, max_memory
) -> dict:
    """The output side shared by the photo routes (the CLI's output flags): the core's map
    request (spheremap::trace::generate::MapRequest), which checks it."""
    _name("mapping", to, "to")
    _name("fill", fill, "fill")
    return dict(
        to=to,
        preset=preset,
        size=_size_any(size, "size"),
        samples=_size_any(samples, "samples"),
        max_samples=_size_any(max_samples, "max_samples"),
        filter=_name("filter", filter, "filter"),
        outside=_name("outside", outside, "outside"),
        seed=_seed(seed),
        look=_vec3(look, "look"),
        up=_vec3(up, "up"),
        max_memory=_max_memory(max_memory),
    )


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


def find_ball(image: _Photo, *, fov: float | None = None, linear: bool = False) -> dict[str, Any]:
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
    return {
        "circle": (cx, cy, r),
        "fit_rms": rms,
        "fit_rms_px": rms if fov is None else None,
        "fit_points": n,
        "confidence": confidence,
        "reflectance": reflectance,
        "uncertainty_px": uncertainty,
    }


def from_mirror_ball(
    image: _Photo,
    *,
    second: _Photo | None = None,
    angle: float = 90.0,
    align: bool = True,
    fov: float | None = None,
    focal: float | None = None,
    sensor: float | None = None,
    orthographic: bool = False,
    circle: npt.ArrayLike | None = None,
    circle2: npt.ArrayLike | None = None,
    reflectance: float | npt.ArrayLike | None = None,
    camera_radius: float = 20.0,
    fill: str = "none",
    size: int = 512,
    samples: int = 4,
    max_samples: int = 1024,
    filter: str = "box",
    outside: str = "gutter",
    to: str = "sphere",
    preset: str | None = None,
    look: npt.ArrayLike | None = None,
    up: npt.ArrayLike | None = None,
    seed: int = 0,
    linear: bool = False,
    nonfinite: str = "error",
    max_memory: int | None = None,
) -> _PhotoResult:
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
        raise ValueError(
            "fov: the photo's field of view is unknown (an array has no EXIF): give fov, "
            "focal and sensor, or orthographic=True"
        )
    out = _map_out(to, preset, size, samples, max_samples, filter, outside, seed, look, up, fill, max_memory)
    a, exif = _photo(image, "image", linear, nonfinite)
    b, exif2 = (None, None) if second is None else _photo(second, "second", linear, nonfinite)
    if reflectance is None:
        refl = (1.0, 1.0, 1.0)
    else:
        try:
            r = np.atleast_1d(np.asarray(reflectance, dtype=np.float64))
        except (TypeError, ValueError):
            raise ValueError(
                f"reflectance: expected one positive number or three, got {reflectance!r}"
            ) from None
        if r.ndim != 1 or len(r) not in (1, 3) or not np.all((r > 0) & np.isfinite(r)):
            raise ValueError(f"reflectance: expected one positive number or three, got {reflectance!r}")
        r3 = np.broadcast_to(r, 3)
        refl = (float(r3[0]), float(r3[1]), float(r3[2]))
    fov = None if fov is None else _finite(fov, "fov")
    focal = None if focal is None else _finite(focal, "focal")
    sensor = None if sensor is None else _finite(sensor, "sensor")
    m, mask, info = _ext.from_mirror_ball(
        image=a,
        exif=exif,
        second=b,
        exif2=exif2,
        orthographic=bool(orthographic),
        fov=fov,
        focal=focal,
        sensor=sensor,
        circle=_circle(circle, "circle"),
        circle2=_circle(circle2, "circle2"),
        angle=_finite(angle, "angle"),
        align=bool(align),
        reflectance=refl,
        camera_radius=_finite(camera_radius, "camera_radius"),
        request=out,
        fill=fill,
    )
    return _cube_out(to, m), _cube_out(to, mask), info


def from_fisheye(
    image: _Photo,
    *,
    model: str,
    fov: float,
    centre: npt.ArrayLike | None = None,
    radius: float | None = None,
    k: npt.ArrayLike | None = None,
    fill: str = "none",
    size: int = 512,
    samples: int = 4,
    max_samples: int = 1024,
    filter: str = "box",
    outside: str = "gutter",
    to: str = "sphere",
    preset: str | None = None,
    look: npt.ArrayLike | None = None,
    up: npt.ArrayLike | None = None,
    seed: int = 0,
    linear: bool = False,
    nonfinite: str = "error",
    max_memory: int | None = None,
) -> _PhotoResult:
    """A sphere map of the camera's view from a fisheye photo (``spheremap from-fisheye``).

    model: one of LENS_MODELS; fov: the field of view in degrees across the image circle;
    centre: the optical centre (cx, cy) in continuous pixel coordinates (default the image
    centre); radius: the image circle's radius in pixels (default half the shorter side);
    k: (k1, k2, k3, k4) of the polynomial model r/f = θ(1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸).
    Other arguments and the result as from_mirror_ball; the mask is the covered fraction of each
    texel (0 for the directions the lens did not see).
    """
    _name("lens", model, "model")
    if k is not None and model != "polynomial":
        raise ValueError("k: only the polynomial model takes coefficients")
    kk = (0.0, 0.0, 0.0, 0.0)
    if k is not None:
        ka = _floats(k, "k", last=(4,), ndim=1)
        if not np.all(np.isfinite(ka)):
            raise ValueError(f"k: must be finite, got {k!r}")
        kk = (float(ka[0]), float(ka[1]), float(ka[2]), float(ka[3]))
    c = None
    if centre is not None:
        ca = _floats(centre, "centre", last=(2,), ndim=1)
        if not np.all(np.isfinite(ca)):
            raise ValueError(f"centre: must be finite, got {centre!r}")
        c = (float(ca[0]), float(ca[1]))
    out = _map_out(to, preset, size, samples, max_samples, filter, outside, seed, look, up, fill, max_memory)
    a, _ = _photo(image, "image", linear, nonfinite)
    m, mask, info = _ext.from_fisheye(
        image=a,
        model=model,
        k=kk,
        fov=_finite(fov, "fov"),
        centre=c,
        radius=None if radius is None else _finite(radius, "radius"),
        request=out,
        fill=fill,
    )
    return _cube_out(to, m), _cube_out(to, mask), info
