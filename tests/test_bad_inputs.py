"""The bad-input corpus (tests/bad_inputs/, made by make_corpus.py) through the CLI and the
Python API: exit code 2, one line naming the file and the cause, no output file; Python raises
an exception naming the file or argument."""

from pathlib import Path

import numpy as np
import pytest

import spheremap as sm
from conftest import cli

CORPUS = Path(__file__).parent / "bad_inputs"

BAD_IMAGES = {
    "truncated.exr": "cannot decode OpenEXR",
    "garbage.exr": "not an image",
    "truncated.png": "cannot decode PNG",
    "truncated.jpg": "truncated",
    "garbage.webp": "cannot decode WebP",
    "empty.png": "the file is empty",
    "truncated.hdr": "cannot decode Radiance HDR",
    "garbage.hdr": "cannot decode Radiance HDR",
    "truncated.pfm": "truncated",
    "absurd.hdr": "over the limit",
    "absurd.pfm": "over the limit",
    "absurd.png": "cannot decode PNG",
}

BAD_MESHES = {
    "index_out_of_range.obj": "out of bounds",
    "garbage.obj": "cannot read OBJ",
    "no_geometry.obj": "no ",
    "bad_mtl.obj": "malformed OBJ/MTL",
    "broken.gltf": "cannot read glTF",
    "missing_buffer.gltf": "cannot read glTF",
}


def assert_refused(r, name, msg, out=None):
    assert r.returncode == 2, (name, r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert name in lines[0] and msg in lines[0], lines[0]
    assert "panicked" not in r.stderr and "internal error" not in r.stderr
    if out is not None:
        assert not out.exists()
        assert not list(out.parent.glob(".*tmp*")), list(out.parent.iterdir())


@pytest.mark.parametrize("name,msg", sorted(BAD_IMAGES.items()))
def test_bad_images_cli(tmp_path, name, msg):
    out = tmp_path / "out.exr"
    assert_refused(cli("info", CORPUS / name), name, msg)
    assert_refused(cli("convert", CORPUS / name, out, "--from", "latlong", "--to", "sphere"), name, msg, out)
    assert_refused(cli("generate", "--env", CORPUS / name, "-o", out), name, msg, out)


@pytest.mark.parametrize("name,msg", sorted(BAD_IMAGES.items()))
def test_bad_images_python(name, msg):
    with pytest.raises(sm.Error, match=msg) as e:
        sm.read_image(CORPUS / name)
    assert name in str(e.value)
    if "limit" in msg:
        assert isinstance(e.value, sm.LimitError)
    else:
        assert isinstance(e.value, sm.DataError)


@pytest.mark.parametrize("name,msg", sorted(BAD_MESHES.items()))
def test_bad_meshes(tmp_path, name, msg):
    out = tmp_path / "out.png"
    assert_refused(cli("generate", "--scene", CORPUS / name, "-o", out), name, msg, out)
    csv = tmp_path / "st.csv"
    assert_refused(cli("texgen", CORPUS / name, "--modelview", "identity", "-o", csv), name,
                   msg.replace("no ", "no"), csv)
    with pytest.raises((sm.Error, OSError)) as e:
        sm.Scene.load(CORPUS / name)
    assert name in str(e.value)


def test_format_by_content_not_name(tmp_path):
    # PNG bytes named .exr are read as the PNG they are; info says so.
    with pytest.warns(UserWarning, match="holds PNG but its extension names OpenEXR"):
        img = sm.read_image(CORPUS / "png_named.exr")
    assert img.shape == (32, 32, 3)
    r = cli("info", CORPUS / "png_named.exr")
    assert r.returncode == 0 and "the content is PNG" in r.stdout


def test_shape_errors(tmp_path):
    out = tmp_path / "o.exr"
    assert_refused(cli("convert", CORPUS / "nonsquare_sphere.png", out, "--from", "sphere", "--to", "latlong"),
                   "nonsquare_sphere.png", "square", out)
    assert_refused(cli("convert", CORPUS / "faces_{face}.png", out, "--from", "cube", "--to", "sphere"),
                   "faces_nz.png", "8x8", out)
    with pytest.raises(ValueError, match="^image"):
        sm.convert(np.zeros((32, 64, 3), np.float32), "sphere", "latlong")


def test_nonfinite_pixels(tmp_path):
    img = np.ones((16, 32, 3), np.float32)
    img[3, 5, 1] = np.nan
    img[7, 9, 0] = np.inf
    src = tmp_path / "nan.exr"
    sm.write_image(src, img)
    out = tmp_path / "o.exr"
    r = cli("convert", src, out, "--from", "latlong", "--to", "sphere", "--size", "16")
    assert_refused(r, "nan.exr", "2 NaN/Inf values (the first at pixel x=5, y=3)", out)
    r = cli("convert", src, out, "--from", "latlong", "--to", "sphere", "--size", "16", "--nonfinite", "zero", "-q")
    assert r.returncode == 0, r.stderr
    assert np.isfinite(sm.read_image(out)).all()
    with pytest.raises(ValueError, match=r"^image: 2 NaN/Inf values \(the first at pixel x=5, y=3\)"):
        sm.convert(img, "latlong", "sphere", size=16)
    assert np.isfinite(sm.convert(img, "latlong", "sphere", size=16, nonfinite="zero")).all()
    assert np.isnan(sm.convert(img, "latlong", "sphere", size=16, nonfinite="keep")).any()
    r = cli("info", src)
    assert r.returncode == 0 and "NaN" in r.stdout


def test_memory_and_size_limits(tmp_path):
    out = tmp_path / "o.exr"
    r = cli("convert", "testdata/apartment.exr", out, "--from", "latlong", "--to", "sphere", "--size", "4096",
            "--max-memory", "64M")
    assert_refused(r, "size", "over the memory limit", out)
    with pytest.raises(sm.LimitError, match="^size: the job needs"):
        sm.convert(np.ones((8, 16, 3), np.float32), "latlong", "sphere", size=4096, max_memory=1 << 20)
    with pytest.raises(sm.LimitError, match="over the memory limit"):
        sm.generate(4096, sm.Scene.builtin("octants"), max_memory=1 << 20)
    r = cli("generate", "--scene", "builtin:octants", "--size", "4096", "--max-memory", "1M", "-o", out)
    assert_refused(r, "size", "over the memory limit", out)
    r = cli("convert", "testdata/apartment.exr", out, "--from", "latlong", "--to", "sphere", "--max-memory", "lots")
    assert_refused(r, "max-memory", "cannot read", out)
    r = cli("convert", "testdata/apartment.exr", out, "--from", "latlong", "--to", "sphere", "--size", "0")
    assert_refused(r, "size", "out of range", out)
    r = cli("convert", "testdata/apartment.exr", out, "--from", "latlong", "--to", "sphere", "--samples", "100000")
    assert_refused(r, "samples", "out of range", out)


def test_info_check_exit_codes(tmp_path):
    # 1 = ran fine, found a problem; 0 = clean; 2 = could not read.
    r = cli("info", CORPUS / "png_named.exr", "--check")
    assert r.returncode == 1 and "named OpenEXR but holds PNG" in r.stderr, r.stderr
    assert cli("info", "testdata/apartment.exr", "--check").returncode == 0
    img = np.ones((4, 8, 3), np.float32)
    img[1, 2, 0] = np.nan
    sm.write_image(tmp_path / "n.exr", img)
    r = cli("info", tmp_path / "n.exr", "--check")
    assert r.returncode == 1 and "1 NaN/Inf" in r.stderr
    assert cli("info", CORPUS / "garbage.exr", "--check").returncode == 2


def test_devices_and_folders_are_not_read(tmp_path):
    for path in ["/dev/zero", tmp_path]:
        r = cli("info", path)
        assert r.returncode == 2 and ("not a regular file" in r.stderr or "directory" in r.stderr)
    with pytest.raises(sm.DataError, match="not a regular file"):
        sm.read_image("/dev/zero")


def test_degenerate_triangles_reported(tmp_path):
    (tmp_path / "d.obj").write_text("v 0 0 -1\nv 1 0 -1\nv 0 1 -1\nv 2 2 -1\nf 1 2 3\nf 1 2 2\nf 4 4 4\n")
    r = cli("generate", "--scene", tmp_path / "d.obj", "--size", "16", "--json", "-o", tmp_path / "o.exr")
    assert r.returncode == 0, r.stderr
    import json
    assert json.loads(r.stdout)["degenerate_triangles"] == 2


def test_pixel_limit_from_the_environment(tmp_path):
    import os
    env = dict(os.environ, SPHEREMAP_MAX_PIXELS="1000")
    r = cli("info", "testdata/apartment.exr", env=env)
    assert r.returncode == 2 and "over the limit" in r.stderr and "1000 pixels" in r.stderr
