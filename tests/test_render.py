"""The rasterizer: per-vertex against Mesa's fixed-function pipeline, the CLI and Python."""

import json
import math

import numpy as np
import pytest

import spheremap as sm
from conftest import cli

TEAPOT = "crates/spheremap/data/teapot.obj"


def glu(eye, target, up, fovy, near, far, w, h):
    """gluLookAt and gluPerspective, written out independently of the core."""
    eye, target, up = (np.asarray(v, np.float64) for v in (eye, target, up))
    f = target - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    c = 1 / math.tan(math.radians(fovy / 2))
    p = np.zeros((4, 4))
    p[0, 0], p[1, 1] = c * h / w, c
    p[2, 2], p[2, 3], p[3, 2] = (far + near) / (near - far), 2 * far * near / (near - far), -1
    return m, p


@pytest.fixture(scope="module")
def teapot():
    return sm.load_mesh(TEAPOT)


@pytest.fixture(scope="module")
def texture():
    env = sm.read_image("testdata/apartment.exr")
    sph = sm.convert(env, "latlong", "sphere", size=256)
    rgb = np.round(np.clip(sph / (1 + sph), 0, 1) * 255).astype(np.uint8)
    return np.concatenate([rgb, np.full(rgb.shape[:2] + (1,), 255, np.uint8)], -1)


@pytest.mark.parametrize("direction, dist, size", [((0.5, 0.6, 1.0), 2.2, (320, 240)),
                                                   ((-1.0, 0.3, -0.4), 1.6, (256, 256))])
def test_per_vertex_matches_mesa(mesa, teapot, texture, direction, dist, size):
    p, n, t = teapot
    lo, hi = p.min(0), p.max(0)
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    d = np.asarray(direction) / np.linalg.norm(direction)
    eye, up, fovy, near, far = centre + d * dist * radius, (0, 1, 0), 40.0, 0.3 * radius, 6 * radius
    w, h = size
    m, proj = glu(eye, centre, up, fovy, near, far, w, h)
    gl = mesa.mesa_render_sphere_map(p, n, t, m, proj, texture, size)[..., :3].astype(int)
    cam = dict(eye=eye, target=centre, up=up, fovy=fovy, near=near, far=far, size=size)
    ours = sm.render((p, n, t), texture[..., :3].astype(np.float32) / 255, mode="per-vertex", **cam)
    ours = np.round(np.clip(ours, 0, 1) * 255).astype(int)
    covered = sm.render((p, n, t), mode="error", **cam)[..., 1] > 0
    gl_covered = (gl != 0).any(-1)  # the background is black; the texture has no black texel
    union = covered | gl_covered
    diff = np.abs(ours - gl).max(-1)[union]
    within = (diff <= 2).mean()
    print(f"{union.sum()} covered pixels: {100 * within:.2f} % within 2/255, "
          f"{100 * (diff <= 1).mean():.2f} % within 1/255, coverage differs on {(covered ^ gl_covered).sum()}")
    assert union.sum() > 0.1 * w * h
    assert within >= 0.99
    assert (covered ^ gl_covered).sum() <= 0.005 * union.sum()


def test_render_modes_through_the_cli(tmp_path):
    sph = tmp_path / "sph.exr"
    r = cli("convert", "testdata/apartment.exr", sph, "--from", "latlong", "--to", "sphere", "--size", 128, "-q")
    assert r.returncode == 0, r.stderr
    for mode, extra in [("per-vertex", ()), ("per-pixel", ()), ("normals", ()),
                        ("matcap", ("--matcap-variant", "perspective")), ("error", ())]:
        env = ("--env", "testdata/matcap_0177.webp") if mode == "matcap" else ("--env", sph)
        r = cli("render", TEAPOT, *env, "--mode", mode, *extra, "--size", 96, 64, "--aa", 2, "--json",
                "-o", tmp_path / f"{mode}.png")
        assert r.returncode == 0, (mode, r.stderr)
        s = json.loads(r.stdout)
        assert s["covered_pixels"] > 500 and s["width"] == 96
        assert sm.read_image(tmp_path / f"{mode}.png").shape == (64, 96, 3)
    assert s["error_deg"]["max"] > s["error_deg"]["mean"] > 0
    # Per-pixel with a lat-long map, and an HDR EXR output kept linear (not tone-mapped).
    const = tmp_path / "const.exr"
    sm.write_image(const, np.full((32, 64, 3), 7.5, np.float32))
    r = cli("render", TEAPOT, "--env", const, "--env-format", "latlong", "--size", 48, 48, "-o", tmp_path / "c.exr")
    assert r.returncode == 0, r.stderr
    img = sm.read_image(tmp_path / "c.exr")
    assert np.isclose(img.max(), 7.5, rtol=1e-5) and set(np.unique(np.round(img, 3))) <= {0.0, 7.5}
    # The camera as given: the JSON reports the gluLookAt/gluPerspective matrices.
    r = cli("render", TEAPOT, "--mode", "normals", "--eye", 0, 10, 60, "--target", 0, 0, 0, "--fovy", 30,
            "--near", 1, "--far", 200, "--size", 64, 48, "--json", "-o", tmp_path / "n.exr")
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    m, proj = glu((0, 10, 60), (0, 0, 0), (0, 1, 0), 30, 1, 200, 64, 48)
    np.testing.assert_allclose(s["modelview"], m, atol=1e-12)
    np.testing.assert_allclose(s["projection"], proj, atol=1e-12)
    # The same camera as one spec (the texgen command's lookat: form).
    r = cli("render", TEAPOT, "--mode", "normals", "--camera", "lookat:0,10,60,0,0,0,0,1,0", "--fovy", 30,
            "--near", 1, "--far", 200, "--size", 64, 48, "--json", "-o", tmp_path / "n2.exr")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["modelview"] == s["modelview"]
    np.testing.assert_array_equal(sm.read_image(tmp_path / "n2.exr"), sm.read_image(tmp_path / "n.exr"))


def test_render_cli_errors(tmp_path):
    out = tmp_path / "o.png"
    for args, msg in [
        ((tmp_path / "missing.obj", "--mode", "normals"), "missing.obj"),
        ((TEAPOT, "--mode", "shiny"), "mode"),
        ((TEAPOT, "--mode", "per-pixel"), "--env"),
        ((TEAPOT, "--mode", "per-vertex", "--env", "testdata/apartment.exr", "--env-format", "latlong"), "--from: "),
        ((TEAPOT, "--mode", "normals", "--fovy", 180), "fovy"),
        ((TEAPOT, "--mode", "normals", "--aa", 0), "aa"),
        ((TEAPOT, "--mode", "normals", "--tonemap", "filmic"), "tonemap"),
        ((TEAPOT, "--mode", "normals", "--camera", "1,2,3"), "camera"),
        ((TEAPOT, "--mode", "normals", "--subpixel-bits", 9), "subpixel"),
    ]:
        r = cli("render", *args, "-o", out)
        assert r.returncode == 2, (args, r.stderr)
        assert msg in r.stderr and r.stderr.count("\n") == 1, (args, r.stderr)
        assert not out.exists()


def test_python_render_errors(teapot):
    p, n, t = teapot
    with pytest.raises(ValueError, match="^mode"):
        sm.render((p, n, t), mode="shiny")
    with pytest.raises(ValueError, match="^env"):
        sm.render((p, n, t), mode="per-pixel")
    with pytest.raises(ValueError, match="^triangles"):
        sm.render((p, n, t.astype(np.float32)), mode="normals")
    with pytest.raises(ValueError, match="^triangles"):
        sm.render((p, n, t + 10_000), mode="normals")
    with pytest.raises(ValueError, match="^normals"):
        sm.render((p, n[:5], t), mode="normals")
    with pytest.raises(ValueError, match="^mesh"):
        sm.render(42, mode="normals")
    for bits in (0, 9, 2.5):
        with pytest.raises(ValueError, match="^subpixel_bits"):
            sm.render((p, n, t), mode="normals", size=(16, 16), subpixel_bits=bits)
    # Coarser vertex snapping moves the vertices by under 1/16 pixel: the coverage changes on a
    # few edge pixels and the interpolated normals by little.
    fine = sm.render((p, n, t), mode="normals", size=(192, 128))
    coarse = sm.render((p, n, t), mode="normals", size=(192, 128), subpixel_bits=4)
    cf, cc = fine.max(axis=2) > 0, coarse.max(axis=2) > 0
    assert 0 < (cf != cc).sum() < 0.02 * cf.sum()
    both = cf & cc
    d = np.abs(fine[both] - coarse[both])
    assert 0 < d.mean() < 0.005 and d.max() < 0.1
    # Normals None: angle-weighted ones are computed (as for an OBJ without vn).
    a = sm.render((p, None, t), mode="normals", size=(32, 32))
    b = sm.render((p, n, t), mode="normals", size=(32, 32))
    assert a.shape == b.shape == (32, 32, 3)


def test_python_render_takes_a_cube_env_in_any_layout(teapot):
    """A cube env as (6, F, F, C) faces, or one image in a layout (env_layout, or implied by its
    shape as in convert), draws the same picture; a 6:1 image must be named."""
    p, n, t = teapot
    hdri = sm.read_image("testdata/apartment.exr")
    faces = sm.convert(hdri, "latlong", "cube", size=16)
    kw = dict(mode="per-pixel", env_format="cube", size=(48, 32))
    want = sm.render((p, n, t), faces, **kw)
    assert want.std() > 0.01
    for layout in sm.CUBE_LAYOUTS:
        img = sm.cube_to_layout(faces, layout)
        np.testing.assert_array_equal(sm.render((p, n, t), img, env_layout=layout, **kw), want, err_msg=layout)
    np.testing.assert_array_equal(sm.render((p, n, t), sm.cube_to_layout(faces, "vcross"), **kw), want)
    with pytest.raises(ValueError, match="^env: a 96x16 image could be 'hstrip'"):
        sm.render((p, n, t), sm.cube_to_layout(faces, "hstrip"), **kw)
    with pytest.raises(ValueError, match="^src_layout: only for src='cube'"):
        sm.render((p, n, t), hdri, mode="per-pixel", env_format="latlong", env_layout="hcross")


def test_a_sphere_map_in_another_preset_renders_as_the_gl_one(teapot, tmp_path):
    """Texgen addresses a GL sphere map; one in another preset (named, or noted in its file)
    is resampled into it first, so it is not drawn mirrored. Read as GL, it would be."""
    p, n, t = teapot
    hdri = sm.read_image("testdata/apartment.exr")
    gl = sm.convert(hdri, "latlong", "sphere", size=64)
    sky = sm.convert(hdri, "latlong", "sphere", size=64, dst_preset="skylibs")
    for mode in ["per-vertex", "per-pixel"]:
        kw = dict(mode=mode, size=(64, 48))
        want = sm.render((p, n, t), gl, **kw)
        got = sm.render((p, n, t), sky, env_preset="skylibs", **kw)
        wrong = sm.render((p, n, t), sky, **kw)
        assert np.abs(got - want).mean() < 0.1 * np.abs(wrong - want).mean(), mode
    # The CLI takes the preset from the file's note.
    sm.write_image(tmp_path / "sky.exr", sky, mapping="sphere", preset="skylibs")
    sm.write_image(tmp_path / "gl.exr", gl, mapping="sphere")
    for f in ["sky", "gl"]:
        r = cli("render", TEAPOT, "--env", tmp_path / f"{f}.exr", "--size", 64, 48, "-o", tmp_path / f"{f}.exr.out.exr", "-q")
        assert r.returncode == 0, r.stderr
    a, b = (sm.read_image(tmp_path / f"{f}.exr.out.exr") for f in ["sky", "gl"])
    assert np.abs(a - b).mean() < 0.1 * np.abs(wrong - want).mean()


def test_python_render_reads_the_files_note(teapot, tmp_path):
    """render(mesh, path) takes env_format/env_preset/env_layout from the file's note, as the
    CLI does; a flag given wins."""
    p, n, t = teapot
    hdri = sm.read_image("testdata/apartment.exr")
    kw = dict(mode="per-pixel", size=(48, 32))
    sm.write_image(tmp_path / "ll.exr", hdri, mapping="latlong")
    np.testing.assert_array_equal(sm.render((p, n, t), tmp_path / "ll.exr", **kw),
                                  sm.render((p, n, t), hdri, env_format="latlong", **kw))
    sky = sm.convert(hdri, "latlong", "sphere", size=64, dst_preset="skylibs")
    sm.write_image(tmp_path / "sky.exr", sky, mapping="sphere", preset="skylibs")
    np.testing.assert_array_equal(sm.render((p, n, t), tmp_path / "sky.exr", **kw),
                                  sm.render((p, n, t), sky, env_preset="skylibs", **kw))
    cross = sm.cube_to_layout(sm.convert(hdri, "latlong", "cube", size=16), "horizon")
    sm.write_image(tmp_path / "h.exr", cross, mapping="cube", layout="horizon")
    np.testing.assert_array_equal(sm.render((p, n, t), tmp_path / "h.exr", **kw),
                                  sm.render((p, n, t), cross, env_format="cube", env_layout="horizon", **kw))
    # A file without a note is a sphere map unless told; a flag given wins over the note.
    sm.write_image(tmp_path / "plain.exr", sky)
    np.testing.assert_array_equal(sm.render((p, n, t), tmp_path / "plain.exr", **kw), sm.render((p, n, t), sky, **kw))
    np.testing.assert_array_equal(sm.render((p, n, t), tmp_path / "sky.exr", env_preset="gl", **kw),
                                  sm.render((p, n, t), sky, **kw))
