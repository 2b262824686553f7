"""The lists of names each option takes; the core defines each once (spheremap's Rust crate), these are its lists."""

from __future__ import annotations

from typing import Any

from . import _spheremap as _ext

# The lists of names are the core's (spheremap's Rust crate defines each once).
NORMALIZE_MODES = tuple(_ext.names("normalize"))
SINGULAR_MODES = tuple(_ext.names("singular"))
MATCAP_VARIANTS = tuple(_ext.names("matcap"))
#: Environment mappings (dir_to_uv, uv_to_dir, texel_solid_angles, convert).
MAPPINGS = tuple(_ext.names("mapping"))
#: KTX2/DDS texel encodings (write_texture's encode, the CLI's --encode).
ENCODINGS = tuple(_ext.names("encode"))
#: Cube-map file layouts (see the README's diagram); "dice" (py360convert's name) is accepted
#: for "hcross".
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
#: Texture wrap of render's sphere map or MatCap.
WRAPS = tuple(_ext.names("wrap"))

#: The older spellings of the source's keywords, {alias: keyword}: `from*` (conversions),
#: `env_*` (lighting, render, view) and `environment_mapping`, `environment_preset` (scenes) for
#: `src`, `src_preset`, `src_layout`, `src_look`, `src_up` (the core's jobs::source::ALIASES, as
#: recipes take them).
SOURCE_ALIASES: dict[str, str] = dict(_ext.source_aliases())


def limits() -> dict[str, dict[str, Any]]:
    """Every limit the entry points enforce, by name (``spheremap limits``; docs/limits.md):
    ``{"map_size": {"value": 32768, "min": 1, "unit": "texels", "what": ..., "env": None}, ...}``.
    ``value`` is the largest accepted (for ``image_pixels`` and ``memory``, the default as
    ``$SPHEREMAP_MAX_PIXELS`` / ``$SPHEREMAP_MAX_MEMORY`` leave it in this process)."""
    return {r.pop("name"): r for r in _ext.limits()}
