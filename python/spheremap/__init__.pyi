import os
from typing import Any, Callable, Literal, NamedTuple

import numpy as np
import numpy.typing as npt

__version__: str

class Error(ValueError): ...
class DataError(Error): ...
class UnsupportedError(Error): ...
class LimitError(Error): ...

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
def info(path: str | os.PathLike[str], *, linear: bool = False) -> dict[str, Any]: ...
def write_image(path: str | os.PathLike[str], array: _ArrayLike, *, linear: bool = False, bits: int = 8, half: bool = False,
                clamp_half: bool = False, mapping: str | None = None, preset: str | None = None, layout: str | None = None,
                look: npt.ArrayLike | None = None, up: npt.ArrayLike | None = None) -> dict[str, int]: ...
MAPPINGS: tuple[str, ...]
def dir_to_uv(dirs: _ArrayLike, mapping: str = "latlong", *, preset: str | None = None) -> npt.NDArray[np.float64]: ...
def uv_to_dir(uv: _ArrayLike, mapping: str = "latlong", *, preset: str | None = None) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]: ...
def texel_solid_angles(mapping: str, width: int, height: int | None = None, *, preset: str | None = None) -> npt.NDArray[np.float64]: ...
CUBE_LAYOUTS: tuple[str, ...]
FILTERS: tuple[str, ...]
TAPS: tuple[str, ...]
def convert(image: npt.ArrayLike, src: str, dst: str, *, size: int | None = None, samples: int = 4,
            max_samples: int = 1024, filter: str = "box", outside: str = "gutter",
            look: npt.ArrayLike | None = None, up: npt.ArrayLike | None = None,
            yaw: float | None = None, pitch: float | None = None, roll: float | None = None,
            src_look: npt.ArrayLike | None = None, src_up: npt.ArrayLike | None = None,
            src_preset: str | None = None, dst_preset: str | None = None,
            src_layout: str | None = None,
            seed: int = 0, precision: str = "f32", nonfinite: str = "error",
            max_memory: int | None = None,
            out: npt.NDArray[np.float32] | None = None,
            taps: str = "bilinear") -> npt.NDArray[np.float32]: ...
def cube_from_layout(image: npt.ArrayLike, layout: str) -> npt.NDArray[np.float32]: ...
def cube_to_layout(faces: npt.ArrayLike, layout: str = "hcross") -> npt.NDArray[np.float32]: ...

class Scene:
    @classmethod
    def load(cls, path: str | os.PathLike[str], *, background: npt.ArrayLike | None = None,
             environment: npt.ArrayLike | None = None, environment_mapping: str = "latlong",
             environment_preset: str | None = None, shading: str = "full", max_depth: int = 8,
             indirect_samples: int = 1, seed: int = 0) -> Scene: ...
    @classmethod
    def builtin(cls, name: str = "demo", *, reflectance: float = 0.75, **kwargs: object) -> Scene: ...
    @property
    def triangle_count(self) -> int: ...
    @property
    def light_count(self) -> int: ...
    @property
    def bounds(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]: ...
    def set_background(self, colour: npt.ArrayLike) -> None: ...
    def set_environment(self, image: npt.ArrayLike, mapping: str = "latlong", *,
                        preset: str | None = None) -> None: ...
    def add_point_light(self, position: npt.ArrayLike, intensity: npt.ArrayLike) -> None: ...
    def add_directional_light(self, direction: npt.ArrayLike, irradiance: npt.ArrayLike) -> None: ...
    def __call__(self, origins: npt.ArrayLike, directions: npt.ArrayLike) -> npt.NDArray[np.float32]: ...
    def intersect(self, origins: npt.ArrayLike, directions: npt.ArrayLike) -> npt.NDArray[np.float32]: ...
    def preview(self, eye: npt.ArrayLike, target: npt.ArrayLike, *, up: npt.ArrayLike = (0.0, 1.0, 0.0),
                fov: float = 40.0, lens: str | None = None, size: tuple[int, int] = (640, 480),
                samples: int = 16, seed: int = 0) -> npt.NDArray[np.float32]: ...

def generate(size: int, fire_ray: Scene | Callable[[npt.NDArray[np.float32], npt.NDArray[np.float32]], npt.ArrayLike],
             *, pos: npt.ArrayLike = (0.0, 0.0, 0.0), look: npt.ArrayLike | None = None,
             up: npt.ArrayLike | None = None, samples: int = 4, max_samples: int = 1024,
             filter: str = "box", outside: str = "gutter", seed: int = 0, precision: str = "f32",
             mapping: str = "sphere", preset: str | None = None,
             max_memory: int | None = None) -> npt.NDArray[np.float32]: ...

LENS_MODELS: tuple[str, ...]
PHOTO_FILLS: tuple[str, ...]
_Photo = npt.ArrayLike | str | os.PathLike[str]
_PhotoResult = tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], dict[str, Any]]
def find_ball(image: _Photo, *, fov: float | None = None, linear: bool = False) -> dict[str, Any]: ...
def from_mirror_ball(image: _Photo, *, second: _Photo | None = None, angle: float = 90.0,
                     align: bool = True, fov: float | None = None, focal: float | None = None,
                     sensor: float | None = None, orthographic: bool = False,
                     circle: npt.ArrayLike | None = None, circle2: npt.ArrayLike | None = None,
                     reflectance: float | npt.ArrayLike | None = None, camera_radius: float = 20.0,
                     fill: str = "none", size: int = 512, samples: int = 4, max_samples: int = 1024,
                     filter: str = "box", outside: str = "gutter", to: str = "sphere",
                     preset: str | None = None, look: npt.ArrayLike | None = None,
                     up: npt.ArrayLike | None = None, seed: int = 0, linear: bool = False,
                     nonfinite: str = "error", max_memory: int | None = None) -> _PhotoResult: ...
def from_fisheye(image: _Photo, *, model: str, fov: float, centre: npt.ArrayLike | None = None,
                 radius: float | None = None, k: npt.ArrayLike | None = None, fill: str = "none",
                 size: int = 512, samples: int = 4, max_samples: int = 1024, filter: str = "box",
                 outside: str = "gutter", to: str = "sphere", preset: str | None = None,
                 look: npt.ArrayLike | None = None, up: npt.ArrayLike | None = None, seed: int = 0,
                 linear: bool = False, nonfinite: str = "error",
                 max_memory: int | None = None) -> _PhotoResult: ...
RENDER_MODES: tuple[str, ...]
def load_mesh(path: str | os.PathLike[str]) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.uint32]]: ...
def render(mesh: str | os.PathLike[str] | tuple[npt.ArrayLike, npt.ArrayLike | None, npt.ArrayLike],
           env: _Photo | None = None, *, mode: str = "per-pixel", env_format: str | None = None,
           env_preset: str | None = None, matcap_variant: str = "classic",
           eye: npt.ArrayLike | None = None, target: npt.ArrayLike | None = None,
           up: npt.ArrayLike | None = None, fovy: float = 40.0, near: float | None = None,
           far: float | None = None, size: tuple[int, int] = (512, 512),
           background: npt.ArrayLike = (0.0, 0.0, 0.0), aa: int = 1, wrap: str = "clamp-to-edge",
           linear: bool = False, env_layout: str | None = None) -> npt.NDArray[np.float32]: ...
def analyze(map: _Photo | None = None, *, mapping: str = "sphere", preset: str | None = None,
            size: int = 256, mesh: str | os.PathLike[str] | tuple[npt.ArrayLike, npt.ArrayLike | None, npt.ArrayLike] | None = None,
            eye: npt.ArrayLike | None = None, target: npt.ArrayLike | None = None,
            up: npt.ArrayLike | None = None, fovy: float = 40.0, near: float | None = None,
            far: float | None = None, view_size: tuple[int, int] = (512, 512),
            threshold: float = 1.0) -> dict[str, Any]: ...
