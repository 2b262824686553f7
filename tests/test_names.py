"""Every name users type is one of the core's enums: the CLI, Python and a batch recipe take the
same names and aliases, and refuse any other text with the same message, each naming the
argument as it is spelled there (`--roughness-map`, `roughness_map`)."""

import os

import pytest
from conftest import cli, refused_alike, write_recipe

import spheremap as sm

HDRI = "testdata/apartment.exr"


# (argument, bad value, the core's message after "argument: ", CLI arguments, the Python call,
# the recipe's output)
CASES = [
    (
        "filter",
        "lanczos",
        'unknown filter "lanczos"; expected one of: box, tent, gaussian',
        lambda v, out: ["convert", HDRI, out, "--from", "latlong", "--to", "sphere", "--size", 8, "--filter", v],
        lambda v, img: sm.convert(img, "latlong", "sphere", size=8, filter=v),
        lambda v: {"op": "convert", "to": "sphere", "size": 8, "filter": v},
    ),
    (
        "taps",
        "nearest",
        'unknown taps "nearest"; expected one of: bilinear, bicubic',
        lambda v, out: ["convert", HDRI, out, "--from", "latlong", "--to", "sphere", "--size", 8, "--taps", v],
        lambda v, img: sm.convert(img, "latlong", "sphere", size=8, taps=v),
        lambda v: {"op": "convert", "to": "sphere", "size": 8, "taps": v},
    ),
    (
        "roughness_map",
        "unreal",
        'unknown roughness map "unreal"; expected one of: filament, threejs, linear',
        lambda v, out: ["prefilter", HDRI, "-o", out, "--size", 8, "--roughness-map", v],
        lambda v, img: sm.prefilter(img, size=8, roughness_map=v),
        lambda v: {"op": "prefilter", "size": 8, "roughness_map": v},
    ),
    (
        "method",
        "montecarlo",
        'unknown method "montecarlo"; expected one of: tree, sampled',
        lambda v, out: ["prefilter", HDRI, "-o", out, "--size", 8, "--method", v],
        lambda v, img: sm.prefilter(img, size=8, method=v),
        lambda v: {"op": "prefilter", "size": 8, "method": v},
    ),
    (
        "encode",
        "bc7",
        'unknown encoding "bc7"; expected one of: float, bc6h, rgb9e5, rgbd, rgbm, uastc-hdr-4x4, astc-hdr-6x6',
        lambda v, out: ["prefilter", HDRI, "-o", out, "--size", 8, "--encode", v],
        lambda v, img: sm.write_texture(os.devnull + ".ktx2", [img], encode=v),
        lambda v: {"op": "prefilter", "size": 8, "encode": v},
    ),
]

# The photo routes' requests: a name, and values checked by the request itself (not a name),
# refused alike by `from-photo` / `from-fisheye`, Python and a `from-photo` / `from-fisheye`
# recipe.
CASES += [
    (
        "fill",
        "magic",
        'unknown fill "magic"; expected one of: none, smooth, mean',
        lambda v, out: ["from-photo", HDRI, "--fov", 30, "--fill", v, "-o", out],
        lambda v, img: sm.from_mirror_ball(img, fov=30, fill=v),
        lambda v: {"op": "from-photo", "fov": 30, "fill": v},
    ),
    (
        "model",
        "fishy",
        'unknown lens model "fishy"; expected one of: equidistant, equisolid, stereographic, orthographic, '
        "polynomial",
        lambda v, out: ["from-fisheye", HDRI, "--model", v, "--fov", 180, "-o", out],
        lambda v, img: sm.from_fisheye(img, model=v, fov=180),
        lambda v: {"op": "from-fisheye", "model": v, "fov": 180},
    ),
    (
        "reflectance",
        (1, 2),
        "give one value or three (R G B), not 2",
        lambda v, out: ["from-photo", HDRI, "--fov", 30, "--reflectance", *v, "-o", out],
        lambda v, img: sm.from_mirror_ball(img, fov=30, reflectance=v),
        lambda v: {"op": "from-photo", "fov": 30, "reflectance": list(v)},
    ),
    (
        "camera_radius",
        95,
        "must be in [0°, 90°)",
        lambda v, out: ["from-photo", HDRI, "--fov", 30, "--camera-radius", v, "-o", out],
        lambda v, img: sm.from_mirror_ball(img, fov=30, camera_radius=v),
        lambda v: {"op": "from-photo", "fov": 30, "camera_radius": v},
    ),
]

# (argument, an alias, CLI arguments, the Python call, the recipe's output): taken everywhere.
ALIASES = [
    (
        "filter",
        "triangle",
        lambda v, out: ["convert", HDRI, out, "--from", "latlong", "--to", "sphere", "--size", 8, "--filter", v],
        lambda v, img: sm.convert(img, "latlong", "sphere", size=8, filter=v),
        lambda v: {"op": "convert", "to": "sphere", "size": 8, "filter": v},
    ),
    (
        "roughness_map",
        "three",
        lambda v, out: ["prefilter", HDRI, "-o", out, "--size", 8, "--roughness-map", v],
        lambda v, img: sm.prefilter(img, size=8, roughness_map=v),
        lambda v: {"op": "prefilter", "size": 8, "roughness_map": v},
    ),
]


@pytest.fixture(scope="module")
def hdri():
    return sm.read_image(HDRI)


@pytest.mark.parametrize("case", range(len(CASES)))
def test_a_name_not_in_the_list_is_refused_alike_everywhere(case, hdri, tmp_path):
    arg, bad, cause, cli_args, call, recipe = CASES[case]
    refused_alike(cli, tmp_path, HDRI, hdri, bad, arg, cause, cli_args, call, recipe)


@pytest.mark.parametrize("case", range(len(ALIASES)))
def test_an_alias_is_taken_alike_everywhere(case, hdri, tmp_path):
    arg, alias, cli_args, call, recipe = ALIASES[case]
    out = tmp_path / ("out.ktx2" if recipe(alias)["op"] == "prefilter" else "out.exr")
    r = cli(*cli_args(alias, out))
    assert r.returncode == 0 and out.exists(), r.stderr
    call(alias, hdri)
    lib, rp = write_recipe(tmp_path, recipe(alias), HDRI)
    r = cli("batch", lib, "--recipe", rp, "--out", tmp_path / "made")
    assert r.returncode == 0, r.stderr


def test_every_list_is_the_cores_and_aliases_are_not_listed():
    assert sm.FILTERS == ("box", "tent", "gaussian")
    assert sm.WRAPS == ("clamp-to-edge", "repeat")
    assert "dice" not in sm.CUBE_LAYOUTS and "hcross" in sm.CUBE_LAYOUTS
    # py360convert's name for the horizontal cross is taken.
    cube = sm.convert(sm.read_image(HDRI), "latlong", "cube", size=4)
    assert sm.cube_to_layout(cube, "dice").shape == sm.cube_to_layout(cube, "hcross").shape


def test_the_built_in_scenes_and_shadings_are_the_cores_names(tmp_path):
    cause = 'unknown built-in scene "nope"; expected one of: demo, octants, mirror-ball'
    out = tmp_path / "m.exr"
    r = cli("generate", "--scene", "builtin:nope", "-o", out, "--size", 8)
    assert r.returncode == 2 and r.stderr.strip() == f"spheremap: --scene: {cause}", r.stderr
    with pytest.raises(ValueError) as e:
        sm.Scene.builtin("nope")
    assert str(e.value) == f"name: {cause}"
    cause = 'unknown shading "flat"; expected one of: full, emission'
    r = cli("generate", "--scene", "builtin:octants", "-o", out, "--size", 8, "--shading", "flat")
    assert r.returncode == 2 and r.stderr.strip() == f"spheremap: --shading: {cause}", r.stderr
    with pytest.raises(ValueError) as e:
        sm.Scene.builtin("octants", shading="flat")
    assert str(e.value) == f"shading: {cause}"
    assert not out.exists()
    r = cli("generate", "--scene", "builtin:octants", "-o", out, "--size", 8, "--shading", "emission")
    assert r.returncode == 0 and out.exists(), r.stderr
