"""Nothing is lost without a word: values beyond half floats are refused or clamped on request,
clipping is counted, a file whose content disagrees with its name is read with a warning,
errors name their real cause, and a conversion to the same mapping copies the texels."""

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import spheremap as sm
from conftest import cli

CORPUS = Path(__file__).parent / "bad_inputs"
HDRI = "testdata/apartment.exr"
TEAPOT = "crates/spheremap/data/teapot.obj"


def sun_map(tmp_path, value=1.0e6):
    img = np.full((32, 64, 3), 0.5, np.float32)
    img[4, 10] = value
    img[5, 11, 1] = -2 * value
    p = tmp_path / "sun.exr"
    sm.write_image(p, img, mapping="latlong")
    return p, img


def test_half_overflow_is_refused_or_clamped_on_request(tmp_path):
    src, img = sun_map(tmp_path)
    out = tmp_path / "o.exr"
    r = cli("convert", src, out, "--half")
    assert r.returncode == 2, r.stderr
    line = r.stderr.strip()
    assert "\n" not in line and str(out) in line, r.stderr
    assert "4 values lie beyond the half-float range (the largest 2e6" in line, line
    assert "--clamp-half" in line and not out.exists()
    assert not list(tmp_path.glob(".*tmp*"))
    r = cli("convert", src, out, "--half", "--clamp-half", "--json")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["copied"] and summary["clamped_half"] == 4 and summary["clipped"] == 0
    back = sm.read_image(out)
    assert np.isfinite(back).all()
    assert back.max() == 65504 and back.min() == -65504
    # Values within range are exactly what half holds.
    np.testing.assert_array_equal(back[0, 0], np.float16(img[0, 0]).astype(np.float32))
    # The clamp flag needs --half.
    r = cli("convert", src, tmp_path / "p.exr", "--clamp-half")
    assert r.returncode == 2 and "--half" in r.stderr
    # Python: the same rule.
    with pytest.raises(sm.DataError, match="4 values lie beyond the half-float range"):
        sm.write_image(tmp_path / "py.exr", img, half=True)
    assert not (tmp_path / "py.exr").exists()
    assert sm.write_image(tmp_path / "py.exr", img, half=True, clamp_half=True) == {"clipped": 0, "clamped_half": 4}
    assert np.isfinite(sm.read_image(tmp_path / "py.exr")).all()
    with pytest.raises(ValueError, match="^clamp_half"):
        sm.write_image(tmp_path / "q.exr", img, clamp_half=True)
    # 32-bit floats hold everything.
    r = cli("convert", src, tmp_path / "f.exr", "--json")
    assert r.returncode == 0 and json.loads(r.stdout)["clamped_half"] == 0
    np.testing.assert_array_equal(sm.read_image(tmp_path / "f.exr"), img)


def test_clipping_is_counted(tmp_path):
    src, img = sun_map(tmp_path, value=3.0)
    for ext, want in [("png", 4), ("jpg", 4), ("hdr", 1), ("pfm", 0), ("exr", 0)]:
        r = cli("convert", src, tmp_path / f"o.{ext}", "--json")
        assert r.returncode == 0, r.stderr
        assert json.loads(r.stdout)["clipped"] == want, ext
    assert sm.write_image(tmp_path / "p.png", img)["clipped"] == 4
    # Half a quantisation step is not clipping: an 8-bit value read back writes back as is.
    ldr = sm.read_image(tmp_path / "p.png")
    assert sm.write_image(tmp_path / "q.png", ldr)["clipped"] == 0
    r = cli("generate", "--env", src, "--size", "16", "-o", tmp_path / "g.png", "--json")
    assert r.returncode == 0 and "clipped" in json.loads(r.stdout)


def test_content_disagreeing_with_the_name_is_read_with_a_warning(tmp_path):
    named = CORPUS / "png_named.exr"
    warning = f"spheremap: warning: {named}: the file holds PNG but its extension names OpenEXR; reading it as PNG"
    runs = [
        ("convert", named, tmp_path / "c.exr", "--from", "sphere", "--to", "latlong", "--size", "8"),
        ("generate", "--env", named, "--env-format", "sphere", "--size", "8", "-o", tmp_path / "g.exr"),
        ("render", TEAPOT, "--env", named, "--env-format", "sphere", "--mode", "per-pixel", "--size", "32", "32",
         "-o", tmp_path / "r.png"),
        ("preview", "--env", named, "--env-format", "sphere", "--eye", 0, 0, 0, "--target", 0, 0, -1,
         "--size", 16, 16, "-o", tmp_path / "p.exr"),
        ("from-fisheye", named, "--model", "equidistant", "--fov", 180, "--size", 8, "-o", tmp_path / "f.exr"),
        ("from-photo", named, "--orthographic", "--circle", 16, 16, 15, "--size", 8, "-o", tmp_path / "b.exr"),
        ("analyze", named, "--mapping", "sphere", "-o", tmp_path / "a.png"),
    ]
    for args in runs:
        r = cli(*args)
        assert r.returncode == 0, (args[0], r.stderr)
        lines = [l for l in r.stderr.splitlines() if "warning" in l]
        assert lines == [warning], (args[0], r.stderr)
    with pytest.warns(UserWarning, match="the file holds PNG but its extension names OpenEXR"):
        sm.read_image(named)
    # A file whose name agrees says nothing.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sm.read_image(HDRI)
    r = cli("convert", HDRI, tmp_path / "x.exr", "--from", "latlong", "--to", "sphere", "--size", "8")
    assert r.returncode == 0 and "warning" not in r.stderr


@pytest.mark.parametrize("kind", ["missing", "empty", "folder"])
def test_every_entry_point_names_the_real_cause(tmp_path, kind):
    bad = tmp_path / "bad.exr"
    bad_mesh = tmp_path / "bad.obj"
    if kind == "empty":
        bad.write_bytes(b"")
        bad_mesh.write_bytes(b"")
    elif kind == "folder":
        bad.mkdir()
        bad_mesh.mkdir()
    cause = {"missing": "No such file", "empty": "the file is empty", "folder": "is a directory"}[kind]
    out = tmp_path / "out.exr"
    runs = [
        (bad, "convert", bad, out, "--to", "sphere"),
        (bad, "convert", bad, out),
        (bad, "convert", bad, out, "--from", "latlong", "--to", "sphere"),
        (bad, "info", bad),
        (bad, "generate", "--env", bad, "-o", out),
        (bad, "generate", "--env", bad, "--env-format", "latlong", "-o", out),
        (bad_mesh, "generate", "--scene", bad_mesh, "-o", out),
        (bad_mesh, "render", bad_mesh, "--mode", "normals", "-o", tmp_path / "o.png"),
        (bad, "render", TEAPOT, "--env", bad, "--mode", "per-pixel", "-o", tmp_path / "o.png"),
        (bad, "preview", "--env", bad, "--eye", 0, 0, 0, "--target", 0, 0, -1, "-o", out),
        (bad, "from-photo", bad, "-o", out),
        (bad, "from-fisheye", bad, "--model", "equidistant", "--fov", 180, "-o", out),
        (bad, "analyze", bad, "--mapping", "sphere", "-o", tmp_path / "a.png"),
        (bad_mesh, "texgen", bad_mesh, "--modelview", "identity", "-o", tmp_path / "st.csv"),
    ]
    for name, *args in runs:
        r = cli(*args)
        assert r.returncode == 2, (args, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and str(name) in lines[0] and cause in lines[0], (args, r.stderr)
        assert "records no mapping" not in lines[0] and "panicked" not in r.stderr
        assert not out.exists()
    errors = {"missing": FileNotFoundError, "empty": sm.DataError, "folder": sm.DataError}[kind]
    with pytest.raises(errors, match=cause):
        sm.read_image(bad)
    with pytest.raises(errors, match=cause):
        sm.info(bad)


@pytest.mark.parametrize("mapping,extra", [("sphere", []), ("latlong", []), ("angular", []), ("octahedral", []),
                                           ("paraboloid", []), ("cube", []), ("cube", ["--layout", "vcross"]),
                                           ("sphere", ["--preset", "skylibs"])])
def test_a_conversion_to_the_same_mapping_copies_the_texels(tmp_path, mapping, extra):
    src = tmp_path / f"in.exr"
    r = cli("convert", HDRI, src, "--from", "latlong", "--to", mapping, "--size", "64", *extra)
    assert r.returncode == 0, r.stderr
    want = sm.read_image(src)
    # No --to: the mapping, preset, layout and view the file records; the texels are copied.
    for args in [[], ["--to", mapping, *extra], ["--samples", "16"], ["--filter", "gaussian"]]:
        out = tmp_path / "same.exr"
        r = cli("convert", src, out, *args, "--json", "--force")
        assert r.returncode == 0, (args, r.stderr)
        s = json.loads(r.stdout)
        assert s["copied"] and s["to"] == mapping, (args, s)
        np.testing.assert_array_equal(sm.read_image(out), want)
        assert sm.info(out)["recorded"] == sm.info(src)["recorded"]
    # A format change only re-encodes.
    r = cli("convert", src, tmp_path / "same.pfm")
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(sm.read_image(tmp_path / "same.pfm"), want)
    # Another size, or another preset, is a real conversion.
    r = cli("convert", src, tmp_path / "big.exr", "--size", "128", "--json")
    assert r.returncode == 0 and not json.loads(r.stdout)["copied"]


def test_a_turned_map_converted_to_the_same_mapping_keeps_its_view(tmp_path):
    src = tmp_path / "turned.exr"
    r = cli("convert", HDRI, src, "--from", "latlong", "--to", "sphere", "--size", "64", "--look", 1, 0, 0)
    assert r.returncode == 0, r.stderr
    r = cli("convert", src, tmp_path / "o.exr", "--json")
    assert r.returncode == 0 and json.loads(r.stdout)["copied"], r.stderr
    np.testing.assert_array_equal(sm.read_image(tmp_path / "o.exr"), sm.read_image(src))
    assert sm.info(tmp_path / "o.exr")["recorded"]["look"] == [1.0, 0.0, 0.0]
    # With --to, the output is in the world frame unless told otherwise (as before).
    r = cli("convert", src, tmp_path / "w.exr", "--to", "sphere", "--json")
    assert r.returncode == 0 and not json.loads(r.stdout)["copied"]


def test_python_convert_to_the_same_mapping_is_exact():
    img = sm.read_image(HDRI)
    np.testing.assert_array_equal(sm.convert(img, "latlong", "latlong"), img)
    s = sm.convert(img, "latlong", "sphere", size=64)
    np.testing.assert_array_equal(sm.convert(s, "sphere", "sphere"), s)
    assert not np.array_equal(sm.convert(s, "sphere", "sphere", look=(1, 0, 0)), s)


def test_a_lat_long_not_2_to_1_is_named_and_a_map_too_small_for_its_mapping_refused(tmp_path):
    square, wide, one = tmp_path / "square.exr", tmp_path / "wide.exr", tmp_path / "one.exr"
    sm.write_image(square, np.ones((64, 64, 3), np.float32))
    sm.write_image(wide, np.ones((30, 128, 3), np.float32))
    sm.write_image(one, np.ones((1, 1, 3), np.float32))
    for src, aspect in [(square, "64x64 (1.000:1)"), (wide, "128x30 (4.267:1)")]:
        r = cli("convert", src, tmp_path / "o.exr", "--from", "latlong", "--to", "cube", "--size", "4")
        assert r.returncode == 0, r.stderr
        lines = [l for l in r.stderr.splitlines() if "warning" in l]
        assert len(lines) == 1 and f"a lat-long map is 2:1 (2N x N), this one is {aspect}" in lines[0], r.stderr
    with pytest.warns(UserWarning, match=r"this one is 64x64 \(1.000:1\)"):
        sm.convert(sm.read_image(square), "latlong", "cube", size=4)
    # A 2:1 lat-long says nothing.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sm.convert(np.ones((8, 16, 3), np.float32), "latlong", "cube", size=4)
    # One texel cannot be a sphere map: refused, naming the smallest, nothing written.
    out = tmp_path / "s.exr"
    r = cli("convert", one, out, "--from", "sphere", "--to", "latlong", "--size", "8")
    assert r.returncode == 2 and not out.exists()
    assert r.stderr.strip().splitlines() == [f"spheremap: {one}: 1x1 is too small for a sphere map: the smallest is 2x2"]
    with pytest.raises(sm.DataError, match="1x1 is too small for a sphere map: the smallest is 2x2"):
        sm.convert(np.ones((1, 1, 3), np.float32), "sphere", "latlong", size=8)
