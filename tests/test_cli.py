"""The CLI (the Rust binary behind the `spheremap` console script)."""

import json
import math
import shutil

import numpy as np
import pytest

import spheremap as sm
from conftest import cli, write_glb

TEAPOT = "crates/spheremap/data/teapot.obj"


@pytest.fixture
def repo(request):
    return request.config.rootpath


def test_demo_writes_chart_and_teapot(tmp_path):
    r = cli("demo", tmp_path / "d", "--size", 128)
    assert r.returncode == 0, r.stderr
    for f in ["direction_chart.png", "direction_chart.exr", "teapot_spheremap.obj", "teapot_spheremap.mtl", "teapot_texgen.csv",
              "apartment_sphere.exr", "apartment_sphere.png", "raytraced_sphere.exr", "raytraced_sphere.png",
              "teapot_contact_sheet.png", "apartment_matcap_ggx_0.5.exr", "apartment_matcap_ggx_0.5.png"]:
        assert (tmp_path / "d" / f).stat().st_size > 0
    # The demo's sphere map is the bundled HDRI seen from the demo camera (look = target - eye).
    demo = sm.read_image(tmp_path / "d" / "apartment_sphere.exr")
    hdri = sm.read_image("testdata/apartment.exr")
    want = sm.convert(hdri, "latlong", "sphere", size=128, look=(0, -12, -40), up=(0, 1, 0))
    np.testing.assert_allclose(demo, want, rtol=1e-3, atol=1e-3)
    # The MatCap is bake_matcap's of the same HDRI for the same view.
    baked = sm.read_image(tmp_path / "d" / "apartment_matcap_ggx_0.5.exr")
    want = sm.bake_matcap(hdri, material="ggx", roughness=0.5, size=128, look=(0, -12, -40), up=(0, 1, 0))
    np.testing.assert_allclose(baked, want, rtol=1e-3, atol=1e-3)
    # The ray-traced built-in scene is what generate() makes of it.
    traced = sm.read_image(tmp_path / "d" / "raytraced_sphere.exr")
    want = sm.generate(128, sm.Scene.builtin("demo"), pos=(0, 1, 0), samples=16)
    np.testing.assert_array_equal(traced, want)
    st = np.loadtxt(tmp_path / "d" / "teapot_texgen.csv", delimiter=",", skiprows=1)
    assert st.shape == (792, 2) and np.isfinite(st).all()
    assert not list((tmp_path / "d").glob(".*.tmp"))


@pytest.mark.parametrize("ext", ["csv", "npy", "obj"])
def test_texgen_outputs_agree_with_python(tmp_path, repo, ext):
    mesh = repo / TEAPOT
    out = tmp_path / f"t.{ext}"
    r = cli("texgen", mesh, "--modelview", "lookat:0,12,40,0,0,0,0,1,0", "-o", out)
    assert r.returncode == 0, r.stderr
    if ext == "npy":
        st = np.load(out)
    elif ext == "csv":
        st = np.loadtxt(out, delimiter=",", skiprows=1, dtype=np.float32)
    else:
        st = np.array([l.split()[1:] for l in out.read_text().splitlines() if l.startswith("vt ")], np.float32)
        v = np.array([l.split()[1:] for l in out.read_text().splitlines() if l.startswith("v ")], np.float32)
        vn = np.array([l.split()[1:] for l in out.read_text().splitlines() if l.startswith("vn ")], np.float32)
        eye, up = np.array([0, 12, 40.0]), np.array([0, 1.0, 0])
        f = -eye / np.linalg.norm(eye)
        s = np.cross(f, up)
        s /= np.linalg.norm(s)
        u = np.cross(s, f)
        mv = np.eye(4)
        mv[0, :3], mv[1, :3], mv[2, :3] = s, u, -f
        mv[:3, 3] = -mv[:3, :3] @ eye
        np.testing.assert_allclose(sm.sphere_texgen(v, vn, mv), st, atol=2e-6)
    assert st.shape == (792, 2) and np.isfinite(st).all()


def test_texgen_modelview_forms(tmp_path, repo):
    mesh = repo / TEAPOT
    rows = "1 0 0 0  0 1 0 0  0 0 1 -40  0 0 0 1"
    cols = "1 0 0 0  0 1 0 0  0 0 1 0  0 0 -40 1"
    (tmp_path / "mv.txt").write_text(rows)
    outs = []
    for k, args in enumerate([["--modelview", rows], ["--modelview", cols, "--column-major"],
                              ["--modelview", tmp_path / "mv.txt"], ["--modelview", "lookat:0,0,40,0,0,0,0,1,0"],
                              ["--modelview", *rows.split()], ["--modelview", *cols.split(), "--column-major"]]):
        o = tmp_path / f"o{k}.npy"
        r = cli("texgen", mesh, *args, "-o", o)
        assert r.returncode == 0, r.stderr
        outs.append(np.load(o))
        # The mesh may also follow the flag, whichever form the flag takes.
        o2 = tmp_path / f"p{k}.npy"
        r = cli("texgen", *args, mesh, "-o", o2)
        assert r.returncode == 0, r.stderr
        np.testing.assert_array_equal(np.load(o2), outs[-1])
    for o in outs[1:]:
        np.testing.assert_array_equal(o, outs[0])


@pytest.mark.parametrize(
    "args, needle",
    [
        (["texgen", "MESH", "--modelview", "1 2 3", "-o", "OUT.csv"], "--modelview: expected 16 numbers"),
        (["texgen", "MESH", "--modelview", "1", "0", "0", "-o", "OUT.csv"], "--modelview: expected 16 numbers (a 4x4 matrix), got 3"),
        (["texgen", "--modelview", *"1 0 0 0 0 1 0 0 0 0 1 0 0 0 0".split(), "MESH", "-o", "OUT.csv"],
         "--modelview: expected 16 numbers (a 4x4 matrix), got 15"),
        (["texgen", "--modelview", "identity", "-o", "OUT.csv"], "MESH"),
        (["texgen", "MESH", "--modelview", "identity", "-o", "OUT.png"], "unknown output extension"),
        (["texgen", "MISSING.obj", "--modelview", "identity", "-o", "OUT.csv"], "MISSING.obj"),
        (["texgen", "GARBAGE.glb", "--modelview", "identity", "-o", "OUT.csv"], "GARBAGE.glb"),
        (["texgen", "MESH", "--modelview", "identity", "-o", "MESH"], "overwrite the input"),
    ],
)
def test_bad_input_one_line_exit_2_no_output(tmp_path, repo, args, needle):
    mesh = tmp_path / "m.obj"
    shutil.copy(repo / TEAPOT, mesh)
    (tmp_path / "GARBAGE.glb").write_bytes(b"glTF\x02\x00\x00\x00garbage")
    before = mesh.read_bytes()
    args = [str(mesh) if a == "MESH" else str(tmp_path / a) if a.isupper() or "." in a and a.split(".")[0].isupper() else a for a in args]
    r = cli(*args)
    assert r.returncode == 2, r.stderr
    assert needle in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert "panicked" not in r.stderr
    assert not (tmp_path / "OUT.csv").exists() and not (tmp_path / "OUT.png").exists()
    assert mesh.read_bytes() == before


def test_conventions_command_lists_presets():
    r = cli("conventions", "--size", 64)
    assert r.returncode == 0
    for name in sm.presets():
        assert f"\n{name}:" in r.stdout
    assert "+X -> pixel (54.627, 32.000)" in r.stdout


def test_texgen_gltf_applies_node_transforms_to_positions_and_normals(tmp_path):
    positions = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    normals = [[0.6, 0, 0.8], [0, 0.6, 0.8], [0, 0, 1]]
    # Parent: translate; child: non-uniform scale (normals need the inverse transpose).
    nodes = [
        {"translation": [0.5, -0.25, -6.0], "children": [1]},
        {"scale": [2.0, 1.0, 0.5], "mesh": 0},
    ]
    glb = tmp_path / "tri.glb"
    write_glb(glb, positions, normals, [0, 1, 2], nodes, [0])
    out = tmp_path / "st.npy"
    r = cli("texgen", glb, "--modelview", "identity", "-o", out)
    assert r.returncode == 0, r.stderr
    assert "file normals" in r.stderr
    world = np.asarray(positions, np.float64) * [2.0, 1.0, 0.5] + [0.5, -0.25, -6.0]
    wn = np.asarray(normals, np.float64) / [2.0, 1.0, 0.5]
    wn /= np.linalg.norm(wn, axis=1, keepdims=True)
    np.testing.assert_allclose(np.load(out), sm.sphere_texgen(world, wn, np.eye(4)), atol=2e-6)


def test_texgen_obj_with_file_normals(tmp_path):
    obj = tmp_path / "q.obj"
    obj.write_text("v 0 0 -5\nv 1 0 -5\nv 0 1 -5\nvn 0 0 1\nvn 0.6 0 0.8\nvn 0 0.6 0.8\nf 1//1 2//2 3//3\n")
    out = tmp_path / "q.csv"
    r = cli("texgen", obj, "--modelview", "identity", "-o", out)
    assert r.returncode == 0 and "file normals" in r.stderr, r.stderr
    st = np.loadtxt(out, delimiter=",", skiprows=1, dtype=np.float32)
    want = sm.sphere_texgen([[0, 0, -5], [1, 0, -5], [0, 1, -5.0]], [[0, 0, 1], [0.6, 0, 0.8], [0, 0.6, 0.8]], np.eye(4))
    np.testing.assert_array_equal(st, want)


def test_convert_cli_matches_python_and_layouts(tmp_path):
    hdri = "testdata/apartment.exr"
    out = tmp_path / "s.exr"
    r = cli("convert", hdri, out, "--from", "latlong", "--to", "sphere", "--size", 64, "--samples", 9, "--look", 1, 0, 0, "--json")
    assert r.returncode == 0, r.stderr
    import json

    summary = json.loads(r.stdout)
    assert summary["width"] == 64 and summary["to"] == "sphere" and summary["lookups"] >= 9 * 64 * 64 * 0.78
    want = sm.convert(sm.read_image(hdri), "latlong", "sphere", size=64, samples=9, look=(1, 0, 0))
    np.testing.assert_allclose(sm.read_image(out), want, rtol=1e-6, atol=1e-6)
    # Cube: six files by pattern, then a cross read back by shape.
    r = cli("convert", hdri, tmp_path / "f_{face}.exr", "--from", "latlong", "--to", "cube", "--size", 32, "-q")
    assert r.returncode == 0, r.stderr
    faces = np.stack([sm.read_image(tmp_path / f"f_{n}.exr") for n in ["px", "nx", "py", "ny", "pz", "nz"]])
    r = cli("convert", tmp_path / "f_{face}.exr", tmp_path / "cross.exr", "--from", "cube", "--to", "cube", "--size", 32, "--samples", 1, "-q")
    assert r.returncode == 0, r.stderr
    np.testing.assert_allclose(sm.cube_from_layout(sm.read_image(tmp_path / "cross.exr"), "hcross"), faces, atol=1e-5)


def test_convert_cli_six_named_faces(tmp_path):
    """A cube side given as six files named one by one (GL order), or by the {side}, {posx} and
    {index} patterns: the same faces as the {face} pattern and as Python's (6, F, F, C) array."""
    hdri = "testdata/apartment.exr"
    names = ["right", "left", "top", "bottom", "front", "back"]
    named = [tmp_path / f"{n}.exr" for n in names]
    r = cli("convert", hdri, *named, "--from", "latlong", "--to", "cube", "--size", 16, "-q")
    assert r.returncode == 0, r.stderr
    want = sm.convert(sm.read_image(hdri), "latlong", "cube", size=16)
    got = np.stack([sm.read_image(p) for p in named])
    np.testing.assert_array_equal(got, want)
    for pattern, files in [("p_{posx}.exr", ["posx", "negx", "posy", "negy", "posz", "negz"]),
                           ("i_{index}.exr", [str(i) for i in range(6)])]:
        r = cli("convert", hdri, tmp_path / pattern, "--from", "latlong", "--to", "cube", "--size", 16, "-q")
        assert r.returncode == 0, r.stderr
        stem = pattern.split("{")[0]
        np.testing.assert_array_equal(np.stack([sm.read_image(tmp_path / f"{stem}{f}.exr") for f in files]), want)
    # Six named inputs and the {side} pattern read the same faces.
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    r = cli("convert", *named, a, "--from", "cube", "--to", "sphere", "--size", 32, "-q", "--json")
    assert r.returncode == 0, r.stderr
    import json

    assert json.loads(r.stdout)["inputs"] == [str(p) for p in named]
    r = cli("convert", tmp_path / "{side}.exr", b, "--from", "cube", "--to", "sphere", "--size", 32, "-q")
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(sm.read_image(a), sm.read_image(b))
    np.testing.assert_array_equal(sm.read_image(a), sm.convert(want, "cube", "sphere", size=32))
    # Cube to cube: six in and six out (12 paths); seven are ambiguous and refused.
    outs = [tmp_path / f"o{i}.exr" for i in range(6)]
    r = cli("convert", *named, *outs, "--from", "cube", "--to", "cube", "--samples", 1, "-q")
    assert r.returncode == 0, r.stderr
    np.testing.assert_allclose(np.stack([sm.read_image(p) for p in outs]), want, atol=1e-5)
    r = cli("convert", *named, tmp_path / "x.exr", "--from", "cube", "--to", "cube")
    assert r.returncode == 2 and "ambiguous" in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert not (tmp_path / "x.exr").exists()
    r = cli("convert", hdri, tmp_path / "y.exr", tmp_path / "z.exr", "--from", "latlong", "--to", "cube")
    assert r.returncode == 2 and "got 3 paths" in r.stderr, r.stderr
    # A bad sixth output is refused before any work, and none of the six is written.
    bad = [tmp_path / f"n{i}.exr" for i in range(5)] + [tmp_path / "n5.webp"]
    r = cli("convert", hdri, *bad, "--from", "latlong", "--to", "cube")
    assert r.returncode == 2 and "n5.webp" in r.stderr and "does not write" in r.stderr, r.stderr
    assert not any(p.exists() for p in bad)
    # An output that is one of six named inputs is refused.
    before = named[2].read_bytes()
    r = cli("convert", *named, named[2], "--from", "cube", "--to", "sphere")
    assert r.returncode == 2 and "--force" in r.stderr and named[2].read_bytes() == before


def test_convert_cli_errors(tmp_path):
    hdri = "testdata/apartment.exr"
    cases = [
        (["--from", "globe", "--to", "sphere"], "--from: unknown mapping"),
        (["--from", "latlong", "--to", "sphere", "--samples", "0"], "samples:"),
        (["--from", "latlong", "--to", "cube", "--layout", "zigzag"], "layout:"),
        (["--from", "sphere", "--to", "latlong"], "a sphere map is square"),
        (["--from", "latlong", "--to", "sphere", "--look", "0", "0", "0"], "look:"),
    ]
    for extra, msg in cases:
        out = tmp_path / "o.exr"
        r = cli("convert", hdri, out, *extra)
        assert r.returncode == 2, (extra, r.stderr)
        assert msg in r.stderr and r.stderr.count("\n") == 1, (extra, r.stderr)
        assert not out.exists()
    r = cli("convert", tmp_path / "missing_{face}.exr", tmp_path / "o.exr", "--from", "cube", "--to", "sphere")
    assert r.returncode == 2 and "missing_px.exr" in r.stderr
    copy = tmp_path / "in.exr"
    shutil.copy(hdri, copy)
    before = copy.read_bytes()
    r = cli("convert", copy, copy, "--from", "latlong", "--to", "latlong")
    assert r.returncode == 2 and "--force" in r.stderr and copy.read_bytes() == before


def test_outputs_never_overwrite_inputs(tmp_path):
    """Every command that writes a map refuses to overwrite one of its inputs without --force
    (one shared guard), and --force lets it."""
    sph = tmp_path / "sph.exr"
    sm.write_image(sph, np.full((16, 16, 3), 0.5, np.float32))
    faces = tmp_path / "f_{face}.exr"
    r = cli("convert", sph, faces, "--from", "sphere", "--to", "cube", "--size", 8, "-q")
    assert r.returncode == 0, r.stderr
    before = sph.read_bytes()
    for args in [
        ("convert", sph, sph, "--from", "sphere", "--to", "sphere"),
        ("convert", faces, tmp_path / "f_px.exr", "--from", "cube", "--to", "sphere"),  # a face of the input
        ("generate", "--env", sph, "--env-format", "sphere", "--size", 8, "-o", sph),
        ("render", TEAPOT, "--env", sph, "--size", 8, 8, "-o", sph),
        ("analyze", sph, "-o", sph),
    ]:
        r = cli(*args)
        assert r.returncode == 2 and "overwrite the input" in r.stderr, (args, r.stderr)
        assert sph.read_bytes() == before
    r = cli("render", TEAPOT, "--env", sph, "--size", 8, 8, "--force", "-q", "-o", sph)
    assert r.returncode == 0, r.stderr


def test_maps_record_their_mapping(tmp_path):
    """convert notes the mapping, preset and cube layout or face in what it writes: info shows
    it (not a guess), a later convert needs no --from, and other readers open the files."""
    import json

    from PIL import Image

    hdri = "testdata/apartment.exr"
    for ext in ["exr", "png", "jpg", "hdr"]:
        out = tmp_path / f"s.{ext}"
        r = cli("convert", hdri, out, "--from", "latlong", "--to", "sphere", "--preset", "skylibs", "--size", 32, "-q")
        assert r.returncode == 0, r.stderr
        info = json.loads(cli("info", out, "--json").stdout)
        assert info["recorded"] == {"mapping": "sphere", "preset": "skylibs", "layout": None, "face": None,
                                    "look": None, "up": None}, ext
        assert sm.info(out)["recorded"] == info["recorded"]
        assert "recorded in the file by spheremap" in cli("info", out).stdout
        # Without --from: read as what it records (a skylibs sphere map), so the round trip
        # to a GL sphere map matches the direct conversion.
        back = tmp_path / f"gl_{ext}.exr"
        r = cli("convert", out, back, "--to", "sphere", "--size", 32, "--samples", 1, "--json")
        assert r.returncode == 0, r.stderr
        assert (json.loads(r.stdout)["from"], json.loads(r.stdout)["from_preset"]) == ("sphere", "skylibs")
        if ext in ("png", "jpg"):
            with Image.open(out) as im:  # an independent reader
                im.load()
                assert im.size == (32, 32)
                if ext == "png":
                    assert im.text.get("spheremap") == "mapping=sphere preset=skylibs"
    direct = sm.convert(sm.read_image(hdri), "latlong", "sphere", size=32)
    gl = sm.read_image(tmp_path / "gl_exr.exr")
    assert np.median(np.abs(gl - direct)) < 0.2 * np.median(np.abs(gl - direct[:, ::-1]))
    # A --from that disagrees with the note is obeyed, with a one-line note.
    r = cli("convert", tmp_path / "s.exr", tmp_path / "x.exr", "--from", "angular", "--to", "latlong", "--size", 8)
    assert r.returncode == 0 and "records mapping sphere (preset skylibs); reading it as angular" in r.stderr, r.stderr
    # A cube layout and face files record theirs; both convert back without --from.
    r = cli("convert", hdri, tmp_path / "c.png", "--from", "latlong", "--to", "cube", "--layout", "vcross", "--size", 8, "-q")
    assert r.returncode == 0, r.stderr
    assert sm.info(tmp_path / "c.png")["recorded"]["layout"] == "vcross"
    r = cli("convert", hdri, tmp_path / "f_{posx}.exr", "--from", "latlong", "--to", "cube", "--size", 8, "-q")
    assert r.returncode == 0, r.stderr
    assert sm.info(tmp_path / "f_negy.exr")["recorded"]["face"] == "ny"
    for src in ["c.png", "f_{posx}.exr"]:
        r = cli("convert", tmp_path / src, tmp_path / "o.exr", "--to", "sphere", "--size", 16, "-q")
        assert r.returncode == 0, (src, r.stderr)
    r = cli("convert", tmp_path / "f_posz.exr", tmp_path / "o2.exr", "--to", "sphere")
    assert r.returncode == 2 and "one face (pz) of a cube map of six files" in r.stderr, r.stderr
    # A map made for a turned view records it, and converts back to the world frame unasked.
    r = cli("convert", hdri, tmp_path / "v.exr", "--from", "latlong", "--to", "sphere", "--size", 64,
            "--look", 1, 0.5, -1, "--up", 0, 1, 0.2, "-q")
    assert r.returncode == 0, r.stderr
    rec = sm.info(tmp_path / "v.exr")["recorded"]
    assert rec["look"] is not None and np.dot(rec["look"], [1, 0.5, -1]) / np.linalg.norm([1, 0.5, -1]) > 0.999999
    r = cli("convert", tmp_path / "v.exr", tmp_path / "w.exr", "--to", "latlong", "--size", 32, "-q", "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["from_look"] == rec["look"]
    world = sm.convert(sm.read_image(hdri), "latlong", "latlong", size=32)
    ll = sm.read_image(tmp_path / "w.exr")
    unturned = sm.convert(sm.read_image(tmp_path / "v.exr"), "sphere", "latlong", size=32)
    assert np.median(np.abs(ll - world)) < 0.25 * np.median(np.abs(unturned - world))
    # A file without a note needs --from, and says so.
    sm.write_image(tmp_path / "plain.exr", np.ones((8, 16, 3), np.float32))
    assert sm.info(tmp_path / "plain.exr")["recorded"] is None
    r = cli("convert", tmp_path / "plain.exr", tmp_path / "p.exr", "--to", "sphere")
    assert r.returncode == 2 and "records no mapping" in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert not (tmp_path / "p.exr").exists()


def test_preview_without_a_camera_position_is_a_usage_error(tmp_path):
    out = tmp_path / "p.png"
    r = cli("preview", "--scene", "builtin:demo", "-o", out)
    assert r.returncode == 2 and "--eye" in r.stderr and "internal error" not in r.stderr
    assert not out.exists()


def test_the_json_reports_of_preview_turntable_and_from_photo_hold_their_fields(tmp_path):
    """Each --json report is one of the core's report types: every field present, the losses
    of the written file included."""
    hdri = "testdata/apartment.exr"
    r = cli("preview", "--scene", "builtin:mirror-ball", "--env", hdri, "--from", "latlong", "--eye", 0, 0, 5,
            "--target", 0, 0, 0, "--fov", 30, "--size", 64, 48, "--samples", 1, "-o", tmp_path / "ball.png",
            "--json")
    assert r.returncode == 0, r.stderr
    p = json.loads(r.stdout)
    assert {"output", "width", "height", "samples", "focal_px", "seconds", "clipped", "clamped_half"} == set(p)
    assert (p["width"], p["height"], p["samples"]) == (64, 48, 1) and p["focal_px"] > 0
    r = cli("render", TEAPOT, "--mode", "normals", "--size", 16, 16, "--turntable", 3,
            "-o", tmp_path / "t_{frame}.png", "--json")
    assert r.returncode == 0, r.stderr
    t = json.loads(r.stdout)
    assert t["frames"] == 3 and len(t["output"]) == 3 and t["mode"] == "normals"
    assert (t["width"], t["height"]) == (16, 16) and set(t) == {"output", "frames", "mode", "width", "height",
                                                                 "seconds"}
    # The ball (radius 1, 5 away) seen through the preview's lens: its outline is given.
    rad = p["focal_px"] * math.tan(math.asin(0.2))
    r = cli("from-photo", tmp_path / "ball.png", "--fov", 30, "--circle", 32, 24, rad, "--size", 16, "--json",
            "-o", tmp_path / "m.exr")
    assert r.returncode == 0, r.stderr
    f = json.loads(r.stdout)
    for k in ("inputs", "output", "models", "to", "preset", "size", "samples", "fill", "seconds", "shots",
              "seen_fraction", "samples_total", "clipped", "clamped_half"):
        assert k in f, k
    assert f["to"] == "sphere" and f["size"] == 16 and f["output"] == [str(tmp_path / "m.exr")]
