"""The native module (Rust, PyO3): what spheremap's Python modules call. Checked against the
built module by mypy.stubtest in the tests."""

from typing import Any, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "DataError",
    "Error",
    "LimitError",
    "MAX_SPLIT",
    "Scene",
    "UnsupportedError",
    "VIEW_MAX_UPLOAD",
    "ViewServer",
    "__version__",
    "_all_finite",
    "_batch_append",
    "_batch_failed_record",
    "_batch_plan",
    "_batch_prepare",
    "_batch_read_manifest",
    "_batch_recipe",
    "_batch_run_local",
    "_batch_run_task",
    "_batch_summary",
    "_cli_main",
    "analyze_mapping",
    "analyze_mesh",
    "bake_matcap",
    "check_name",
    "convert",
    "cube_layout_of",
    "defaults",
    "dfg_lut",
    "dir_to_pixel",
    "dir_to_sphere",
    "dir_to_uv",
    "find_ball",
    "from_fisheye",
    "from_mirror_ball",
    "generate",
    "info",
    "irradiance_sh",
    "layout_to_stack",
    "limits",
    "load_mesh",
    "map_note",
    "mapping_for",
    "matcap_uv",
    "names",
    "pixel_to_dir",
    "prefilter",
    "presets",
    "read_image",
    "read_texture",
    "reflect",
    "render",
    "render_camera",
    "source_aliases",
    "sphere_texel_solid_angle",
    "sphere_texgen",
    "sphere_to_dir",
    "stack_to_layout",
    "texel_solid_angles",
    "uv_to_dir",
    "write_image",
    "write_texture",
]

__version__: str
MAX_SPLIT: int
VIEW_MAX_UPLOAD: int

class Error(ValueError): ...
class DataError(Error): ...
class UnsupportedError(Error): ...
class LimitError(Error): ...

@final
class Scene:
    def add_directional_light(self, /, direction: Any, irradiance: Any) -> Any: ...
    def add_point_light(self, /, position: Any, intensity: Any) -> Any: ...
    @property
    def bounds(self) -> Any: ...
    @staticmethod
    def builtin(name: str, reflectance: float = 0.75) -> Any: ...
    def intersect(self, /, origins: Any, directions: Any) -> Any: ...
    @property
    def light_count(self) -> Any: ...
    @staticmethod
    def load(path: str) -> Any: ...
    def set_background(self, /, colour: Any) -> Any: ...
    def set_environment(self, /, image: Any, request: dict[str, Any]) -> Any: ...
    def set_options(self, /, shading: Any, max_depth: Any, indirect_samples: Any, seed: int) -> Any: ...
    def trace(self, /, origins: Any, directions: Any) -> Any: ...
    @property
    def triangle_count(self) -> Any: ...

@final
class ViewServer:
    def __new__(
        cls,
        mesh: str | None,
        env: str | None,
        matcap: str | None,
        request: dict[str, Any],
        host: str,
        port: int,
        max_upload: int,
    ) -> ViewServer: ...
    @property
    def url(self) -> str: ...
    @property
    def running(self) -> bool: ...
    @property
    def version(self) -> int: ...
    def close(self) -> None: ...

def _all_finite(a: Any) -> bool: ...
def _cli_main(argv: Any) -> int: ...
def _batch_recipe(text: str, is_json: bool, source: str) -> str: ...
def _batch_plan(
    inputs: list[str], text: str, is_json: bool, source: str, out_dir: str, force: bool
) -> dict[str, Any]: ...
def _batch_prepare(out_dir: str) -> None: ...
def _batch_run_task(
    task: dict[str, Any], text: str, is_json: bool, source: str, out_dir: str, worker: str
) -> dict[str, Any]: ...
def _batch_append(out_dir: str, record: dict[str, Any]) -> None: ...
def _batch_failed_record(task: dict[str, Any], recipe_hash: str, error: str) -> dict[str, Any]: ...
def _batch_run_local(plan: dict[str, Any], text: str, is_json: bool, source: str, workers: int) -> dict[str, Any]: ...
def _batch_summary(
    plan: dict[str, Any], results: list[dict[str, Any] | None], seconds: float, workers: int
) -> dict[str, Any]: ...
def _batch_read_manifest(out_dir: str) -> list[dict[str, Any]]: ...
def analyze_mapping(
    mapping: str,
    preset: str | None,
    width: int | None = None,
    height: int | None = None,
    size: int | None = None,
) -> tuple[
    tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]], dict[str, Any]
]: ...
def analyze_mesh(
    positions: Any, normals: Any, triangles: Any, request: dict[str, Any], threshold: float
) -> dict[str, Any]: ...
def bake_matcap(image: Any, request: dict[str, Any]) -> Any: ...
def check_name(kind: str, value: str, arg: str) -> str: ...
def convert(image: Any, job: dict[str, Any], out: npt.NDArray[np.float32] | None = None) -> Any: ...
def cube_layout_of(width: int, height: int) -> tuple[str | None, str | None]: ...
def defaults(op: str) -> dict[str, Any]: ...
def dfg_lut(size: int) -> Any: ...
def dir_to_pixel(dirs: Any, size: int | None, preset: str | None, singular: Any) -> Any: ...
def dir_to_sphere(dirs: Any, singular: Any) -> Any: ...
def dir_to_uv(dirs: Any, mapping: str, preset: str | None = None) -> Any: ...
def find_ball(image: Any, fov: Any) -> Any: ...
def from_fisheye(
    image: Any, model: Any, k: Any, fov: Any, centre: Any, radius: Any, request: dict[str, Any], fill: str
) -> Any: ...
def from_mirror_ball(
    image: Any,
    exif: Any,
    second: Any,
    exif2: Any,
    orthographic: Any,
    fov: Any,
    focal: Any,
    sensor: Any,
    circle: Any,
    circle2: Any,
    angle: Any,
    align: Any,
    reflectance: Any,
    camera_radius: Any,
    request: dict[str, Any],
    fill: str,
) -> Any: ...
def generate(source: Any, channels: int, request: dict[str, Any]) -> Any: ...
def info(path: str, linear: bool) -> dict[str, Any]: ...
def irradiance_sh(image: Any, request: dict[str, Any]) -> dict[str, Any]: ...
def layout_to_stack(image: Any, layout: str | None) -> Any: ...
def limits() -> list[dict[str, Any]]: ...
def load_mesh(
    path: str,
) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.uint32]]: ...
def map_note(
    mapping: str,
    preset: str | None,
    layout: str | None,
    look: tuple[float, float, float] | None,
    up: tuple[float, float, float] | None,
) -> str | None: ...
def mapping_for(
    path: str, mapping: str | None, preset: str | None, default: str
) -> tuple[str, str, str | None]: ...
def matcap_uv(normals_positions: Any, has_positions: Any, variant: Any, scale: Any) -> Any: ...
def names(kind: str) -> list[str]: ...
def pixel_to_dir(xy: Any, size: int | None, preset: str | None) -> Any: ...
def prefilter(image: Any, request: dict[str, Any]) -> tuple[list[Any], list[Any]]: ...
def presets() -> list[tuple[str, str, list[list[float]], str, bool]]: ...
def read_image(path: str, linear: bool, max_pixels: int | None) -> npt.NDArray[np.float32]: ...
def read_texture(path: str, max_pixels: int | None) -> tuple[list[Any], bool]: ...
def reflect(un: Any) -> Any: ...
def render(
    positions: Any,
    normals: Any,
    triangles: Any,
    env: Any,
    env_mapping: str,
    env_preset: str | None,
    request: dict[str, Any],
) -> Any: ...
def render_camera(
    scene: Any,
    eye: Any,
    target: Any,
    up: tuple[float, float, float] | None,
    fov: Any,
    lens: Any,
    width: int,
    height: int,
    samples: int,
    seed: int,
) -> Any: ...
def source_aliases() -> list[tuple[str, str]]: ...
def sphere_texel_solid_angle(size: int | None) -> Any: ...
def sphere_texgen(
    positions: Any,
    normals: Any,
    modelview: Any,
    normalize: str,
    singular: str,
    precision: str,
    out: npt.NDArray[Any] | None = None,
) -> npt.NDArray[Any]: ...
def sphere_to_dir(st: Any) -> Any: ...
def stack_to_layout(stack: Any, layout: str | None) -> Any: ...
def texel_solid_angles(mapping: str, width: int, height: int, preset: str | None = None) -> Any: ...
def uv_to_dir(uv: Any, mapping: str, preset: str | None = None) -> Any: ...
def write_image(
    path: str,
    array: Any,
    linear: bool,
    png16: bool,
    half: bool,
    clamp_half: bool,
    note: str | None,
    encode: str,
) -> tuple[int, int]: ...
def write_texture(
    path: str,
    levels: list[Any],
    cube: bool,
    half: bool,
    clamp_half: bool,
    note: str | None,
    encode: str,
    zstd: int | None,
) -> list[dict[str, Any]] | None: ...
