"""Maps from photos: mirror balls (one or two shots) and fisheye lenses."""

from __future__ import annotations

from typing import Any

import numpy.typing as npt

from . import _spheremap as _ext
from ._args import _Photo, _PhotoResult, _fields


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
    return _ext.find_ball(image, fov=fov, linear=linear)


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
    return _ext.from_mirror_ball(image, second, _fields(locals(), drop=("image", "second")))


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
    return _ext.from_fisheye(image, _fields(locals(), drop=("image",)))
