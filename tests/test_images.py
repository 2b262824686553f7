"""Image I/O through Python and `spheremap info`."""

import json

import numpy as np
import pytest

import spheremap as sm
from conftest import cli

TESTDATA = "testdata"


@pytest.fixture
def repo(request):
    return request.config.rootpath


def test_read_real_files(repo):
    a = sm.read_image(repo / TESTDATA / "apartment.exr")
    assert a.shape == (256, 512, 3) and a.dtype == np.float32
    assert np.isfinite(a).all() and (a < 0).any() and a.max() > 10
    m = sm.read_image(repo / TESTDATA / "matcap_0177.webp")
    assert m.shape == (512, 512, 3) and 0 <= m.min() and m.max() <= 1
    lin = sm.read_image(repo / TESTDATA / "matcap_0177.webp", linear=True)
    assert (lin >= m - 1e-7).all() and (lin > m).any()  # sRGB decoding darkens


@pytest.mark.parametrize("ext, tol", [("exr", 0), ("pfm", 0), ("hdr", 0.02), ("png", 0.01)])
def test_round_trips(tmp_path, ext, tol):
    rng = np.random.default_rng(0)
    img = rng.uniform(0, 1, size=(7, 13, 3)).astype(np.float32)
    p = tmp_path / f"x.{ext}"
    sm.write_image(p, img)
    back = sm.read_image(p)
    assert back.shape == img.shape
    np.testing.assert_allclose(back, img, atol=tol, rtol=tol)


def test_alpha_grey_half_and_16_bit(tmp_path):
    rgba = np.random.default_rng(1).uniform(0, 1, size=(5, 6, 4)).astype(np.float32)
    sm.write_image(tmp_path / "a.png", rgba, bits=16)
    np.testing.assert_allclose(sm.read_image(tmp_path / "a.png"), rgba, atol=1e-4)
    grey = rgba[:, :, 0]
    sm.write_image(tmp_path / "g.exr", grey, half=True)
    g = sm.read_image(tmp_path / "g.exr")
    assert g.shape == (5, 6, 1)
    np.testing.assert_allclose(g[:, :, 0], grey, rtol=1e-3)


def test_errors(tmp_path):
    with pytest.raises(FileNotFoundError):
        sm.read_image(tmp_path / "missing.exr")
    (tmp_path / "bad.exr").write_bytes(b"v/1\x01garbage")
    with pytest.raises(sm.DataError, match="bad.exr"):
        sm.read_image(tmp_path / "bad.exr")
    with pytest.raises(sm.LimitError, match="over the limit"):
        sm.read_image("testdata/apartment.exr", max_pixels=1000)
    with pytest.raises(ValueError, match="^array"):
        sm.write_image(tmp_path / "x.png", np.zeros((4, 4, 5), np.float32))
    with pytest.raises(ValueError, match="^bits"):
        sm.write_image(tmp_path / "x.png", np.zeros((4, 4, 3), np.float32), bits=12)
    with pytest.raises(ValueError, match="unknown image extension"):
        sm.write_image(tmp_path / "x.tiff", np.zeros((4, 4, 3), np.float32))
    assert not list(tmp_path.glob("x.*"))


def test_info_cli(tmp_path, repo):
    r = cli("info", str(repo / TESTDATA / "apartment.exr"), "--json")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    assert (info["format"], info["width"], info["height"], info["channels"]) == ("OpenEXR", 512, 256, 3)
    assert info["nan"] == 0 and info["negative"] > 0
    assert info["mapping_guess"]["name"] == "latlong" and info["mapping_guess"]["is_a_guess"]
    # A NaN is counted and located; a PNG named .exr is read by content and flagged.
    img = np.ones((4, 8, 3), np.float32)
    img[2, 5, 1] = np.nan
    sm.write_image(tmp_path / "n.pfm", img)
    info = json.loads(cli("info", str(tmp_path / "n.pfm"), "--json").stdout)
    assert info["nan"] == 1 and info["first_non_finite"] == [5, 2]
    sm.write_image(tmp_path / "p.png", np.zeros((4, 4, 3), np.float32))
    (tmp_path / "p.png").rename(tmp_path / "p.exr")
    r = cli("info", str(tmp_path / "p.exr"))
    assert r.returncode == 0 and "the extension says OpenEXR, the content is PNG" in r.stdout
    bad = cli("info", str(tmp_path / "none.hdr"))
    assert bad.returncode == 2 and "none.hdr" in bad.stderr and bad.stderr.count("\n") == 1


def test_info_in_python_is_the_cli_json(tmp_path, repo):
    """sm.info(path) gives what `spheremap info --json` prints; the mapping guess tells
    spheremap's own guttered sphere map from its octahedral map."""
    hdri = repo / TESTDATA / "apartment.exr"
    img = np.ones((4, 8, 3), np.float32)
    img[2, 5, 1] = np.nan
    sm.write_image(tmp_path / "n.pfm", img)
    sm.write_image(tmp_path / "p.png", np.full((4, 4, 3), 0.5, np.float32))
    (tmp_path / "p.png").rename(tmp_path / "p.exr")
    for p in [hdri, tmp_path / "n.pfm", tmp_path / "p.exr"]:
        r = cli("info", str(p), "--json")
        assert r.returncode == 0, r.stderr
        assert json.loads(json.dumps(sm.info(p))) == json.loads(r.stdout), p
    assert sm.info(tmp_path / "n.pfm")["first_non_finite"] == (5, 2)
    assert sm.info(tmp_path / "p.exr")["extension_names"] == "OpenEXR"
    assert sm.info(tmp_path / "p.exr", linear=True)["stats"][0]["max"] == pytest.approx(sm.info(tmp_path / "p.exr")["stats"][0]["max"] ** (1 / 2.2), abs=0.03)
    ll = sm.read_image(hdri)
    guesses = {}
    for dst, outside in [("sphere", "gutter"), ("sphere", "black"), ("octahedral", "gutter")]:
        f = tmp_path / f"{dst}_{outside}.exr"
        sm.write_image(f, sm.convert(ll, "latlong", dst, size=128, outside=outside))
        guesses[dst, outside] = sm.info(f)["mapping_guess"]
    assert guesses["sphere", "gutter"]["name"] == "sphere / angular (disc, with a gutter)"
    assert guesses["sphere", "black"]["name"] == "sphere / mirror ball / angular (disc)"
    assert guesses["octahedral", "gutter"]["name"] == "octahedral or a single cube face"
    assert all(g["is_a_guess"] for g in guesses.values())
    with pytest.raises(FileNotFoundError, match="none.hdr"):
        sm.info(tmp_path / "none.hdr")
    (tmp_path / "junk.exr").write_bytes(b"junk")
    with pytest.raises(sm.DataError, match="junk.exr"):
        sm.info(tmp_path / "junk.exr")


def test_write_image_records_a_mapping(tmp_path, repo):
    """write_image(..., mapping=...) notes what the image is, as the CLI does for its maps; the
    CLI then converts it without --from, with its preset and view."""
    hdri = sm.read_image(repo / TESTDATA / "apartment.exr")
    sph = sm.convert(hdri, "latlong", "sphere", size=32, dst_preset="skylibs", look=(1, 0, 0))
    sm.write_image(tmp_path / "s.png", sph, mapping="sphere", preset="skylibs", look=(1, 0, 0))
    rec = sm.info(tmp_path / "s.png")["recorded"]
    assert (rec["mapping"], rec["preset"], rec["look"], rec["up"]) == ("sphere", "skylibs", [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    sm.write_image(tmp_path / "s.exr", sph, mapping="sphere", preset="skylibs", look=(1, 0, 0))
    r = cli("convert", str(tmp_path / "s.exr"), str(tmp_path / "w.exr"), "--to", "latlong", "--size", "32", "-q")
    assert r.returncode == 0, r.stderr
    world = sm.convert(hdri, "latlong", "latlong", size=32)
    assert np.median(np.abs(sm.read_image(tmp_path / "w.exr") - world)) < 0.05
    cross = sm.cube_to_layout(sm.convert(hdri, "latlong", "cube", size=8), "vcross")
    sm.write_image(tmp_path / "c.exr", cross, mapping="cube", layout="vcross")
    assert sm.info(tmp_path / "c.exr")["recorded"]["layout"] == "vcross"
    sm.write_image(tmp_path / "plain.exr", sph)
    assert sm.info(tmp_path / "plain.exr")["recorded"] is None
    x = np.zeros((4, 4, 3), np.float32)
    for kw, msg in [(dict(mapping="globe"), "^mapping"), (dict(mapping="sphere", preset="nope"), "preset"),
                    (dict(mapping="cube"), "^layout"), (dict(mapping="sphere", layout="hcross"), "^layout"),
                    (dict(preset="gl"), "^mapping"), (dict(mapping="sphere", look=(0, 0, 0)), "^look"),
                    (dict(mapping="sphere", up=(0, 1, 0)), "^up")]:
        with pytest.raises(ValueError, match=msg):
            sm.write_image(tmp_path / "bad.exr", x, **kw)
    assert not (tmp_path / "bad.exr").exists()
