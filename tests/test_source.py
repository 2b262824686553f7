"""The map a command reads is described by one set of options everywhere: src, src_preset,
src_layout, src_look, src_up in Python and recipes, --from, --from-preset, --from-layout,
--from-look, --from-up in the CLI. The older spellings (from…, env_…; --src…, --env-…) are the
same options: they give the same result, and one option given twice under two spellings is
refused."""

import json

import numpy as np
import pytest
from conftest import cli, write_recipe

import spheremap as sm

HDRI = "testdata/apartment.exr"

# The source options under each spelling: (CLI flags, Python/recipe keys).
SPELLINGS = [
    (["--from", "--from-preset", "--from-look"], ["src", "src_preset", "src_look"]),
    (["--src", "--src-preset", "--src-look"], ["from", "from_preset", "from_look"]),
    (["--env-format", "--env-preset", "--env-look"], ["env_format", "env_preset", "env_look"]),
]
VALUES = ["sphere", "skylibs", [1.0, 0.0, 0.0]]


@pytest.fixture(scope="module")
def sphere_file(tmp_path_factory):
    """A small skylibs sphere map made for a turned view, in a file with no note."""
    path = tmp_path_factory.mktemp("src") / "ball.exr"
    img = sm.convert(sm.read_image(HDRI), "latlong", "sphere", dst_preset="skylibs", size=16, look=(1, 0, 0))
    sm.write_image(path, img)
    return path


def test_sm_source_aliases_are_the_cores():
    assert sm.SOURCE_ALIASES == {
        "from": "src", "from_preset": "src_preset", "from_layout": "src_layout", "from_look": "src_look",
        "from_up": "src_up", "env_format": "src", "env_preset": "src_preset", "env_layout": "src_layout",
        "env_look": "src_look", "env_up": "src_up", "environment_mapping": "src", "environment_preset": "src_preset",
    }


def test_every_spelling_converts_alike_in_the_cli_python_and_a_recipe(sphere_file, tmp_path):
    ref = sm.convert(sm.read_image(sphere_file), "sphere", "latlong", src_preset="skylibs", src_look=(1, 0, 0),
                     size=8)
    for i, (flags, keys) in enumerate(SPELLINGS):
        args = [a for f, v in zip(flags, VALUES) for a in (f, *(v if isinstance(v, list) else [v]))]
        out = tmp_path / f"cli{i}.exr"
        r = cli("convert", sphere_file, out, *args, "--to", "latlong", "--size", 8)
        assert r.returncode == 0, r.stderr
        np.testing.assert_allclose(sm.read_image(out), ref, rtol=1e-6, atol=1e-7)

        kwargs = dict(zip(keys, VALUES))
        got = sm.convert(sm.read_image(sphere_file), dst="latlong", size=8, **kwargs)
        np.testing.assert_array_equal(got, ref)

        d = tmp_path / f"recipe{i}"
        d.mkdir()
        lib, rp = write_recipe(d, {"op": "convert", "to": "latlong", "size": 8, **kwargs}, sphere_file)
        r = cli("batch", lib, "--recipe", rp, "--out", d / "made")
        assert r.returncode == 0, r.stderr
        np.testing.assert_allclose(sm.read_image(d / "made" / "ball.exr"), ref, rtol=1e-6, atol=1e-7)


def test_the_lighting_requests_take_every_spelling_too(tmp_path):
    """irradiance (CLI, Python) reads the map alike whichever spelling names its mapping."""
    ref = sm.irradiance_sh(sm.read_image(HDRI), src="latlong")["coefficients"]
    for flag, key in [("--from", "src"), ("--src", "from"), ("--env-format", "env_format")]:
        r = cli("irradiance", HDRI, flag, "latlong", "--json")
        assert r.returncode == 0, r.stderr
        np.testing.assert_allclose(json.loads(r.stdout)["coefficients"], ref, rtol=1e-9)
        got = sm.irradiance_sh(sm.read_image(HDRI), **{key: "latlong"})["coefficients"]
        np.testing.assert_allclose(got, ref, rtol=1e-12)


def test_one_option_under_two_spellings_is_refused_everywhere(sphere_file, tmp_path):
    out = tmp_path / "o.exr"
    r = cli("convert", sphere_file, out, "--from", "sphere", "--env-format", "sphere", "--to", "latlong")
    assert r.returncode == 2 and "--from" in r.stderr and "cannot be used multiple times" in r.stderr, r.stderr
    assert not out.exists()
    with pytest.raises(TypeError, match="'src' twice \\(as 'env_format'\\)"):
        sm.convert(sm.read_image(sphere_file), src="sphere", env_format="sphere", dst="latlong")
    lib, rp = write_recipe(tmp_path, {"op": "convert", "src": "sphere", "from": "sphere", "to": "latlong"},
                           sphere_file)
    r = cli("batch", lib, "--recipe", rp, "--out", tmp_path / "made")
    assert r.returncode == 2 and "duplicate field `src`" in r.stderr, r.stderr
    assert not (tmp_path / "made").exists() or not any((tmp_path / "made").iterdir())


def test_a_mistake_is_refused_alike_and_named_as_the_option_is_spelled_there(sphere_file, tmp_path):
    """The core names the field (src_preset) and gives one cause; the CLI prints the field as its
    flag whichever alias was typed, Python and a recipe as the field."""
    r = cli("convert", sphere_file, tmp_path / "o.exr", "--env-format", "sphere", "--env-preset", "nope",
            "--to", "latlong")
    assert r.returncode == 2 and r.stderr.startswith("spheremap: --from-preset: "), r.stderr
    cause = r.stderr.strip().removeprefix("spheremap: --from-preset: ")
    assert "nope" in cause
    with pytest.raises(ValueError) as e:
        sm.convert(sm.read_image(sphere_file), env_format="sphere", env_preset="nope", dst="latlong")
    assert str(e.value) == f"src_preset: {cause}"
    with pytest.raises(ValueError) as e:
        sm.irradiance_sh(sm.read_image(HDRI), env_format="sphere", env_preset="nope")
    assert str(e.value) == f"src_preset: {cause}"
    lib, rp = write_recipe(tmp_path, {"op": "convert", "from": "sphere", "from_preset": "nope", "to": "latlong"},
                           sphere_file)
    r = cli("batch", lib, "--recipe", rp, "--out", tmp_path / "made")
    assert r.returncode == 2 and r.stderr.strip() == f"spheremap: {rp}: output 1: src_preset: {cause}", r.stderr


def test_render_reads_the_map_in_the_worlds_frame_and_refuses_a_source_view(tmp_path):
    out = tmp_path / "o.exr"
    r = cli("render", "crates/spheremap/data/teapot.obj", "--env", HDRI, "--from", "latlong", "--size", 8, 8,
            "--from-look", 1, 0, 0, "-o", out)
    assert r.returncode == 2, r.stderr
    assert r.stderr.startswith("spheremap: --from-look: render reads the map in the world's frame"), r.stderr
    assert not out.exists()


def test_generate_turns_a_map_made_for_a_view_back_into_the_world(tmp_path):
    """A lat-long made for a turned view (convert --look), read with that view (--from-look),
    lights generate's rays as the world-framed original does; read without it, it does not."""
    look, up = (1.0, 0.4, -0.7), (0.2, 1.0, 0.1)
    world = tmp_path / "world.exr"
    sm.write_image(world, sm.convert(sm.read_image(HDRI), "latlong", "latlong", size=64))
    turned = tmp_path / "turned.exr"
    sm.write_image(turned, sm.convert(sm.read_image(HDRI), "latlong", "latlong", size=64, look=look, up=up))

    def generate(env, *flags):
        out = tmp_path / f"g{len(list(tmp_path.iterdir()))}.exr"
        r = cli("generate", "--env", env, "--from", "latlong", *flags, "--to", "latlong", "--size", 16,
                "--samples", 16, "-o", out)
        assert r.returncode == 0, r.stderr
        return sm.read_image(out)

    want = generate(world)
    got = generate(turned, "--from-look", *look, "--from-up", *up)
    unturned = generate(turned)
    err = np.abs(got - want).mean() / want.mean()
    assert err < 0.02, err
    assert np.abs(unturned - want).mean() / want.mean() > 10 * err


def test_a_scenes_environment_made_for_a_view_is_turned_back():
    """Python's scenes read their environment by the same source keywords: a lat-long made for a
    turned view, given that view, lights the rays that miss the ball as the world-framed
    original does (environment_mapping, the scenes' older spelling of src, still reads)."""
    img = sm.read_image(HDRI)
    look, up = (1.0, 0.4, -0.7), (0.2, 1.0, 0.1)
    world = sm.convert(img, "latlong", "latlong", size=64)
    turned = sm.convert(img, "latlong", "latlong", size=64, look=look, up=up)
    a = sm.Scene.builtin("mirror-ball", environment=world)
    b = sm.Scene.builtin("mirror-ball", environment=turned, src_look=look, src_up=up)
    c = sm.Scene.builtin("mirror-ball", environment=turned, environment_mapping="latlong")
    rng = np.random.default_rng(1)
    d = rng.normal(size=(4000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = 10 * d  # outside the ball, looking away from it: every ray misses
    ra, rb, rc = a(o, d), b(o, d), c(o, d)
    err = np.abs(rb - ra).mean() / ra.mean()
    assert err < 0.05, err
    assert np.abs(rc - ra).mean() / ra.mean() > 5 * err
    with pytest.raises(TypeError, match="'src' twice"):
        sm.Scene.builtin("mirror-ball", environment=world, src="latlong", environment_mapping="latlong")
