"""Meshes in, and the GL-exact rasterizer."""

from __future__ import annotations

import os

import numpy as np
import numpy.typing as npt

from . import _spheremap as _ext
from ._args import _Photo, _fields, _source_aliases


def load_mesh(
    path: str | os.PathLike[str],
) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.uint32]]:
    """Reads an OBJ or glTF/GLB mesh -> (positions (N, 3) float32, normals (N, 3) float32,
    triangles (M, 3) uint32): faces triangulated, glTF node transforms applied, the file's
    vertex normals or else angle-weighted ones (see the README)."""
    return _ext.load_mesh(os.fspath(path))


@_source_aliases
def render(
    mesh: str | os.PathLike[str] | tuple[npt.ArrayLike, npt.ArrayLike | None, npt.ArrayLike],
    env: _Photo | None = None,
    *,
    mode: str = "per-pixel",
    src: str | None = None,
    src_preset: str | None = None,
    matcap_variant: str = "classic",
    eye: npt.ArrayLike | None = None,
    target: npt.ArrayLike | None = None,
    up: npt.ArrayLike | None = None,
    fovy: float = 40.0,
    near: float | None = None,
    far: float | None = None,
    size: tuple[int, int] = (512, 512),
    background: npt.ArrayLike = (0.0, 0.0, 0.0),
    aa: int = 1,
    wrap: str = "clamp-to-edge",
    linear: bool = False,
    src_layout: str | None = None,
    subpixel_bits: int = 8,
) -> npt.NDArray[np.float32]:
    """Draws a mesh with the CPU rasterizer (``spheremap render``; see the README).

    mesh: a path (OBJ, glTF/GLB) or (positions (N, 3), normals (N, 3) or None, triangles (M, 3)).
    env: the sphere map (per-vertex, per-pixel), MatCap image (matcap) or environment map in
        `src` (per-pixel), as an array or a path; not needed for normals and error. A
        cube map is (6, F, F, C) faces or one image in a layout (`src_layout`, one of
        CUBE_LAYOUTS, or implied by its shape as in `convert`). src, src_preset and
        src_layout default, for a path, to what spheremap noted in the file when it wrote it
        (as the CLI's --env-format does), else to "sphere". A sphere map in another preset than
        "gl" is resampled into the GL sphere map texgen addresses first.
    mode: one of RENDER_MODES. per-vertex is OpenGL's fixed-function GL_SPHERE_MAP path
        (texgen per vertex, (s, t) interpolated, GL_LINEAR); per-pixel the reflection vector per
        pixel (a sphere map in eye space, other mappings in world space).
    eye, target, up, fovy, near, far: gluLookAt + gluPerspective (defaults frame the mesh).
    size: (width, height). aa: k x k samples per pixel. wrap: "clamp-to-edge" or "repeat".
    subpixel_bits: the vertex snapping of the rasterizer, 1 to 8 bits (8: llvmpipe; 4:
        SwiftShader, what a browser without a GPU draws with).

    Returns linear float32 (H, W, 3), row 0 at the top; for mode="error" (H, W, 2): the angle
    in degrees between the per-vertex and per-pixel lookup directions, and the coverage.
    """
    # The core's render request (spheremap::jobs::render::RenderRequest) checks every field.
    request = _fields(
        dict(mode=mode, matcap_variant=matcap_variant, background=background, aa=aa,
             subpixel_bits=subpixel_bits, wrap=wrap, **_camera(eye, target, up, fovy, near, far, size, "size"))
    )
    return _ext.render(mesh=mesh, env=env, src=src, src_preset=src_preset, src_layout=src_layout, linear=linear,
                       request=request)


def _camera(eye, target, up, fovy, near, far, size, size_name: str) -> dict:
    """The camera fields of the core's render request (as gluLookAt and gluPerspective; `size`
    is (width, height), named `size_name` in errors); the core checks them."""
    try:
        w, h = size
    except (TypeError, ValueError):
        raise ValueError(f"{size_name}: expected (width, height), got {size!r}") from None
    return dict(eye=eye, target=target, up=up, fovy=fovy, near=near, far=far, width=w, height=h)
