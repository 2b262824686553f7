"""The ray-traced generator from Python: callables, scenes, the CLI, errors."""

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import spheremap as sm
from conftest import cli


def sphere_dirs(n):
    """World directions of the texel centres of an n x n sphere map (NaN outside the disc)."""
    x = (np.arange(n) + 0.5) / n
    u, v = np.meshgrid(x, x)
    return sm.uv_to_dir(np.stack([u, v], -1), "sphere")[0]


def test_callable_gets_batches_and_matches_its_own_answer():
    calls = []

    def fire_ray(origins, directions):
        assert origins.dtype == np.float32 and directions.shape[1] == 3
        calls.append(len(directions))
        np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1, atol=1e-5)
        return directions * 0.5 + 0.5

    n = 64
    img = sm.generate(n, fire_ray, samples=1)
    assert img.shape == (n, n, 3) and img.dtype == np.float32
    # Batched: far fewer calls than rays (the probe, then about a row per call).
    assert len(calls) <= n + 1 and max(calls) > 10
    d = sphere_dirs(n)
    inside = np.isfinite(d[..., 0])
    np.testing.assert_allclose(img[inside], (d[inside] * 0.5 + 0.5), atol=2e-5)


def test_callable_channels_and_views():
    img = sm.generate(32, lambda o, d: d[:, 1], samples=4, look=(0, -1, 0), up=(0, 0, -1))
    assert img.shape == (32, 32, 1)
    # Looking down, the map's centre reflects back up: +Y.
    assert img[16, 16, 0] > 0.95


def test_octant_scene_is_exact_with_one_ray():
    scene = sm.Scene.builtin("octants")
    n = 96
    img = sm.generate(n, scene, samples=1)
    d = sphere_dirs(n)
    ok = np.isfinite(d[..., 0]) & (np.abs(d).min(axis=-1) > 1e-3)
    want = np.where(d > 0, 1.0, 0.25)
    np.testing.assert_array_equal(img[ok], want[ok].astype(np.float32))


def test_scene_call_and_intersect():
    scene = sm.Scene.builtin("octants")
    o = np.zeros((4, 3), np.float32)
    d = np.array([[1, 1, 1], [-1, 1, 1], [1, -1, -1], [0.2, 0.3, -0.9]], np.float32)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    np.testing.assert_array_equal(scene(o, d), np.where(d > 0, 1.0, 0.25))
    t = scene.intersect(o, d)
    assert np.all((t > 9.9) & (t <= 10.0))
    assert scene.triangle_count == 8 * 16 * 16
    with pytest.raises(ValueError, match="directions"):
        scene(o, d[:3])


def test_scene_load_obj_with_mtl(tmp_path):
    (tmp_path / "room.mtl").write_text(textwrap.dedent("""
        newmtl glow
        Ke 2 1 0.5
        Kd 0 0 0
        newmtl chrome
        illum 3
        Ks 0.5 0.5 0.5
    """))
    (tmp_path / "room.obj").write_text(textwrap.dedent("""
        mtllib room.mtl
        v -10 -1 -10
        v 10 -1 -10
        v 10 -1 10
        v -10 -1 10
        v -10 5 -10
        v 10 5 -10
        v 10 5 10
        v -10 5 10
        usemtl chrome
        f 1 2 3
        f 1 3 4
        usemtl glow
        f 5 7 6
        f 5 8 7
    """))
    scene = sm.Scene.load(tmp_path / "room.obj", background=(0, 0, 1))
    o = np.zeros((3, 3), np.float32)
    d = np.array([[0, 1, 0], [0, -1, 0], [1, 0, 0]], np.float32)
    c = scene(o, d)
    np.testing.assert_allclose(c[0], [2, 1, 0.5])          # the glowing ceiling
    np.testing.assert_allclose(c[1], [1, 0.5, 0.25])       # the mirror floor shows it, x Ks
    np.testing.assert_allclose(c[2], [0, 0, 1])            # out through the open side: sky
    emission = sm.Scene.load(tmp_path / "room.obj", shading="emission")
    np.testing.assert_allclose(emission(o, d)[1], [0, 0, 0])


GLTF = {
    "asset": {"version": "2.0"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1, 1, 1], "intensity": 8.0}]}},
    "scene": 0,
    "scenes": [{"nodes": [0, 1]}],
    "nodes": [{"mesh": 0}, {"translation": [0, 2, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
    "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0}}],
    "buffers": [{"byteLength": 60, "uri": None}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-10, 0, -10], "max": [10, 0, 10]},
        {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}],
}


def test_scene_load_gltf_with_point_light(tmp_path):
    import base64
    pos = np.array([[-10, 0, -10], [10, 0, -10], [10, 0, 10], [-10, 0, 10]], np.float32)
    idx = np.array([0, 2, 1, 0, 3, 2], np.uint16)
    data = pos.tobytes() + idx.tobytes()
    g = json.loads(json.dumps(GLTF))
    g["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
    p = tmp_path / "floor.gltf"
    p.write_text(json.dumps(g))
    scene = sm.Scene.load(p, indirect_samples=0)
    assert scene.light_count == 1
    c = scene(np.array([[0, 1, 0]], np.float32), np.array([[0, -1, 0]], np.float32))
    # Straight below the light: L = rho / pi * I / d^2.
    np.testing.assert_allclose(c[0], 0.5 / np.pi * 8 / 4, rtol=1e-4)


def test_deterministic_and_seeded():
    scene = sm.Scene.builtin("demo")
    a = sm.generate(48, scene, pos=(0, 1, 0), samples=4)
    b = sm.generate(48, scene, pos=(0, 1, 0), samples=4)
    c = sm.generate(48, scene, pos=(0, 1, 0), samples=4, seed=3)
    np.testing.assert_array_equal(a, b)
    assert np.any(a != c)


def test_cube_faces_route():
    scene = sm.Scene.builtin("demo")
    faces = sm.generate(64, scene, pos=(0, 1, 0), mapping="cube", samples=4)
    assert faces.shape == (6, 64, 64, 3)
    two = sm.convert(faces, "cube", "sphere", size=64)
    direct = sm.generate(64, scene, pos=(0, 1, 0), samples=4)
    inside = np.isfinite(sphere_dirs(64)[..., 0])
    err = np.sqrt(np.mean((two[inside] - direct[inside]) ** 2))
    psnr = 20 * np.log10(direct[inside].max() / err)
    assert psnr > 25, psnr


def test_errors_name_the_argument():
    scene = sm.Scene.builtin("octants")
    with pytest.raises(ValueError, match="^size"):
        sm.generate(0, scene)
    with pytest.raises(ValueError, match="^samples"):
        sm.generate(8, scene, samples=0)
    with pytest.raises(ValueError, match="^up"):
        sm.generate(8, scene, up=(0, 1, 0))
    with pytest.raises(TypeError, match="^fire_ray"):
        sm.generate(8, "not callable")
    with pytest.raises(ValueError, match="^fire_ray"):
        sm.generate(8, lambda o, d: np.zeros((len(o) + 1, 3)))
    with pytest.raises(FileNotFoundError):
        sm.Scene.load("/nonexistent/scene.obj")
    with pytest.raises(ValueError, match="^name"):
        sm.Scene.builtin("nope")

    class Boom(Exception):
        pass

    def bad(o, d):
        if len(o) > 1:
            raise Boom("from the callable")
        return np.zeros((len(o), 3))

    with pytest.raises(Boom, match="from the callable"):
        sm.generate(16, bad)


def test_cli_generate(tmp_path):
    r = cli("generate", "--scene", "builtin:octants", "--size", "64", "--samples", "1", "--json",
            "-o", str(tmp_path / "oct.exr"))
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["rays_per_texel"] == 1.0 and summary["triangles"] == 2048
    img = sm.read_image(tmp_path / "oct.exr")
    d = sphere_dirs(64)
    ok = np.isfinite(d[..., 0]) & (np.abs(d).min(axis=-1) > 1e-3)
    np.testing.assert_array_equal(img[ok], np.where(d > 0, 1.0, 0.25)[ok].astype(np.float32))
    # The cube faces of the two-step route, then convert them.
    r = cli("generate", "--scene", "builtin:demo", "--pos", "0", "1", "0", "--size", "32",
            "--faces-out", str(tmp_path / "faces"), "--faces-size", "16", "-q",
            "-o", str(tmp_path / "demo.png"))
    assert r.returncode == 0, r.stderr
    assert sorted(os.listdir(tmp_path / "faces")) == sorted(f"{f}.exr" for f in ("px", "nx", "py", "ny", "pz", "nz"))
    r = cli("generate", "--env", str(tmp_path / "faces" / "{face}.exr"), "--env-format", "cube",
            "--size", "32", "-q", "-o", str(tmp_path / "from_faces.exr"))
    assert r.returncode == 0, r.stderr


def test_cli_generate_errors(tmp_path):
    out = tmp_path / "x.png"
    for args, msg in [
        (("--scene", str(tmp_path / "missing.obj")), "missing.obj"),
        (("--scene", "builtin:nope"), "--scene"),
        (("--scene", "builtin:demo", "--size", "0"), "size"),
        (("--scene", "builtin:demo", "--samples", "0"), "samples"),
        (("--scene", "builtin:demo", "--shading", "pretty"), "shading"),
        ((), "--scene"),
    ]:
        r = cli("generate", *args, "-o", str(out))
        assert r.returncode == 2, (args, r.stderr)
        assert msg in r.stderr and r.stderr.count("\n") == 1, (args, r.stderr)
        assert not out.exists()


def test_obj_diffuse_texture_under_a_sun(tmp_path):
    # A 2x2 texture: top row red, green; bottom row blue, white (linear values via EXR).
    tex = np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [1, 1, 1]]], np.float32)
    sm.write_image(tmp_path / "tex.exr", tex)
    (tmp_path / "q.mtl").write_text("newmtl t\nKd 1 1 1\nmap_Kd tex.exr\n")
    (tmp_path / "q.obj").write_text(textwrap.dedent("""
        mtllib q.mtl
        v -1 0 -1
        v 1 0 -1
        v 1 0 1
        v -1 0 1
        vt 0 1
        vt 1 1
        vt 1 0
        vt 0 0
        usemtl t
        f 1/1 2/2 3/3
        f 1/1 3/3 4/4
    """))
    scene = sm.Scene.load(tmp_path / "q.obj", indirect_samples=0)
    scene.add_directional_light((0, -1, 0), (np.pi, np.pi, np.pi))
    # OBJ vt (0, 1) is the image's top-left: vertex 1 (-1, 0, -1). Texel centres sit a quarter
    # of the quad in from each corner.
    o = np.array([[-0.5, 1, -0.5], [0.5, 1, -0.5], [-0.5, 1, 0.5], [0.5, 1, 0.5]], np.float32)
    d = np.tile(np.array([[0, -1, 0]], np.float32), (4, 1))
    np.testing.assert_allclose(scene(o, d), tex.reshape(4, 3), atol=1e-5)


def test_cli_ctrl_c_cancels_and_writes_nothing(tmp_path):
    import signal
    import time
    out = tmp_path / "big.exr"
    # The child gets Ctrl-C's default disposition: a shell starts background jobs with SIGINT
    # ignored, the child would inherit that, and Python (rightly) keeps an ignored SIGINT
    # ignored — the cause of this test hanging when the suite ran in the background.
    p = subprocess.Popen([sys.executable, "-m", "spheremap", "generate", "--scene", "builtin:demo",
                          "--size", "2048", "--samples", "256", "-q", "-o", str(out)],
                         stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # Long enough for the interpreter to start and enter the command even on a loaded
    # machine (the work itself runs for minutes); before that, Ctrl-C is Python's own.
    time.sleep(3)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 2, err
    assert "cancelled" in err and err.count("\n") == 1, err
    assert not out.exists() and not list(tmp_path.iterdir())
