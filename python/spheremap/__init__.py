"""spheremap — exact, documented and fast sphere maps.

Conventions (see ``spheremap conventions`` and the README): eye space is right-handed, +Y up,
the viewer looks down -Z. A sphere map's centre (s,t) = (1/2, 1/2) is the direction +Z (back at
the viewer); its whole rim is -Z. Image arrays are (H, W, C) with row 0 at the top = t = 1.
Texel i of n has its centre at (i + 1/2)/n.

Every function takes float32 or float64 arrays (any memory order; Python sequences are read as
float64) and raises ``ValueError`` naming the argument for a wrong shape or dtype.
"""

from __future__ import annotations

from ._spheremap import DataError, Error, LimitError, UnsupportedError, __version__
from .names import (
    CUBE_LAYOUTS,
    ENCODINGS,
    FILTERS,
    LENS_MODELS,
    MAPPINGS,
    MATCAP_VARIANTS,
    NORMALIZE_MODES,
    PHOTO_FILLS,
    RENDER_MODES,
    SINGULAR_MODES,
    SOURCE_ALIASES,
    TAPS,
    WRAPS,
    limits,
)
from .texgen import (
    Preset,
    dir_to_pixel,
    dir_to_sphere,
    matcap_uv,
    pixel_to_dir,
    presets,
    reflect,
    sphere_texel_solid_angle,
    sphere_texgen,
    sphere_to_dir,
)
from .images import info, read_image, read_texture, write_image, write_texture
from .mappings import dir_to_uv, texel_solid_angles, uv_to_dir
from .convert import convert, cube_from_layout, cube_to_layout
from .scene import Scene, generate
from .photo import find_ball, from_fisheye, from_mirror_ball
from .render import load_mesh, render
from .analyze import analyze
from .lighting import bake_matcap, dfg_lut, irradiance_sh, prefilter
from .view import Viewer, view
from . import batch

__all__ = [
    "limits",
    "bake_matcap",
    "irradiance_sh",
    "dfg_lut",
    "prefilter",
    "read_texture",
    "write_texture",
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
    "ENCODINGS",
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
    "WRAPS",
    "SOURCE_ALIASES",
    "find_ball",
    "from_mirror_ball",
    "from_fisheye",
    "RENDER_MODES",
    "load_mesh",
    "render",
    "analyze",
    "view",
    "batch",
    "Viewer",
]
