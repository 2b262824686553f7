import os
from typing import Literal, NamedTuple

import numpy as np
import numpy.typing as npt

__version__: str

class Error(ValueError): ...
class DataError(Error): ...
class UnsupportedError(Error): ...

NORMALIZE_MODES: tuple[str, ...]
SINGULAR_MODES: tuple[str, ...]
MATCAP_VARIANTS: tuple[str, ...]

_Float = np.float32 | np.float64
_ArrayLike = npt.ArrayLike

def sphere_texgen(
    positions: _ArrayLike,
    normals: _ArrayLike,
    modelview: _ArrayLike,
    *,
    normalize: Literal["on", "off", "rescale"] = "on",
    singular: Literal["nan", "center"] = "nan",
    precision: Literal["f32", "f64"] = "f32",
    out: npt.NDArray[_Float] | None = None,
) -> npt.NDArray[_Float]: ...
def dir_to_sphere(dirs: _ArrayLike, *, singular: Literal["nan", "center"] = "nan") -> npt.NDArray[_Float]: ...
def sphere_to_dir(st: _ArrayLike) -> tuple[npt.NDArray[_Float], npt.NDArray[np.bool_]]: ...
def reflect(incident: _ArrayLike, normal: _ArrayLike) -> npt.NDArray[_Float]: ...
def matcap_uv(
    normals: _ArrayLike,
    positions: _ArrayLike | None = None,
    *,
    variant: Literal["classic", "threejs", "perspective"] = "classic",
    scale: float | None = None,
) -> npt.NDArray[_Float]: ...
def sphere_texel_solid_angle(size: int) -> npt.NDArray[np.float64]: ...

class Preset(NamedTuple):
    name: str
    doc: str
    frame: npt.NDArray[np.float64]
    rows: str
    v_down: bool

def presets() -> dict[str, Preset]: ...
def dir_to_pixel(
    dirs: _ArrayLike, size: int, *, preset: str = "gl", singular: Literal["nan", "center"] = "nan"
) -> npt.NDArray[np.float64]: ...
def pixel_to_dir(xy: _ArrayLike, size: int, *, preset: str = "gl") -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]: ...
def read_image(path: str | os.PathLike[str], *, linear: bool = False, max_pixels: int | None = None) -> npt.NDArray[np.float32]: ...
def write_image(path: str | os.PathLike[str], array: _ArrayLike, *, linear: bool = False, bits: int = 8, half: bool = False) -> None: ...
MAPPINGS: tuple[str, ...]
def dir_to_uv(dirs: _ArrayLike, mapping: str = "latlong", *, preset: str | None = None) -> npt.NDArray[np.float64]: ...
def uv_to_dir(uv: _ArrayLike, mapping: str = "latlong", *, preset: str | None = None) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]: ...
def texel_solid_angles(mapping: str, width: int, height: int | None = None, *, preset: str | None = None) -> npt.NDArray[np.float64]: ...
CUBE_LAYOUTS: tuple[str, ...]
FILTERS: tuple[str, ...]
def convert(image: npt.ArrayLike, src: str, dst: str, *, size: int | None = None, samples: int = 4,
            max_samples: int = 1024, filter: str = "box", outside: str = "gutter",
            look: npt.ArrayLike | None = None, up: npt.ArrayLike | None = None,
            yaw: float | None = None, pitch: float | None = None, roll: float | None = None,
            src_look: npt.ArrayLike | None = None, src_up: npt.ArrayLike | None = None,
            src_preset: str | None = None, dst_preset: str | None = None,
            seed: int = 0, precision: str = "f32") -> npt.NDArray[np.float32]: ...
def cube_from_layout(image: npt.ArrayLike, layout: str) -> npt.NDArray[np.float32]: ...
def cube_to_layout(faces: npt.ArrayLike, layout: str = "hcross") -> npt.NDArray[np.float32]: ...
