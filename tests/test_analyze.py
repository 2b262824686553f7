"""Sampling analytics and the per-vertex error advice."""

import json
import math

import numpy as np

import spheremap as sm
from conftest import cli

TEAPOT = "crates/spheremap/data/teapot.obj"


def test_sphere_map_is_equal_area_and_anisotropic_at_the_rim():
    n = 64
    r = sm.analyze(mapping="sphere", size=n)
    c = (np.arange(n) + 0.5) / n * 2 - 1
    x, y = np.meshgrid(c, c)
    rr = np.hypot(x, y)
    # Every texel wholly inside the disc subtends 16/N^2 sr.
    inside = np.hypot(np.abs(x) + 1 / n, np.abs(y) + 1 / n) < 1
    np.testing.assert_allclose(r["solid_angle"][inside], 16 / n**2, rtol=1e-12)
    # Anisotropy 1/(1 - r^2) = 1/cos^2(theta/2) at the texel centre; off the disc NaN.
    on = rr < 1
    np.testing.assert_allclose(r["anisotropy"][on], 1 / (1 - rr[on] ** 2), rtol=1e-3)
    assert np.isnan(r["anisotropy"][~on]).all()
    # Coarsest step^2 / anisotropy = the texel's solid angle (equal area).
    s1 = np.radians(r["resolution_deg"][inside])
    np.testing.assert_allclose(s1**2 / r["anisotropy"][inside], 16 / n**2, rtol=1e-3)


def test_latlong_and_cube():
    r = sm.analyze(mapping="latlong", size=32)
    assert math.isclose(np.nansum(r["solid_angle"]), 4 * math.pi, rel_tol=1e-9)
    lat = (0.5 - (np.arange(32) + 0.5) / 32) * math.pi
    np.testing.assert_allclose(r["anisotropy"][:, 7], 1 / np.cos(lat), rtol=2e-3)
    c = sm.analyze(np.zeros((6, 8, 8, 3), np.float32), mapping="cube")
    assert c["solid_angle"].shape == (48, 8)
    assert math.isclose(np.nansum(c["solid_angle"]), 4 * math.pi, rel_tol=1e-9)


def test_mesh_advice_and_cli(tmp_path):
    r = sm.analyze(mapping="sphere", size=32, mesh=TEAPOT, threshold=2.0, view_size=(128, 96))
    m = r["mesh"]
    assert len(m["triangle_error_deg"]) == 992
    assert len(m["over"]) > 0 and m["uniform_split"] > 1
    assert (m["split"][m["over"]] > 1).all() and (m["split"][~m["in_view"]] == 1).all()
    assert np.nanmax(m["pixel_error_deg"]) > 2.0
    out = tmp_path / "a.png"
    res = cli("analyze", "--mapping", "sphere", "--size", 32, "--mesh", TEAPOT, "--threshold", 2,
              "--view-size", 128, 96, "--json", "-o", out)
    assert res.returncode == 0, res.stderr
    s = json.loads(res.stdout)
    assert s["mesh"]["over"] == len(m["over"]) and s["mesh"]["uniform_split"] == m["uniform_split"]
    assert s["mesh"]["triangles_after_adaptive"] == m["triangles_after_adaptive"]
    assert s["anisotropy"]["min"] >= 1 and math.isclose(s["solid_angle_sr"]["max"], 16 / 32**2)
    img = sm.read_image(out)
    assert img.shape[0] > 32 + 96 and img.shape[2] == 3
    # A map's canvas is analysed as its mapping: a lat-long file.
    res = cli("analyze", "testdata/apartment.exr", "--mapping", "latlong", "--json", "-o", tmp_path / "b.png")
    assert res.returncode == 0, res.stderr
    s = json.loads(res.stdout)
    assert s["width"] == 2 * s["height"]


def test_analyze_errors(tmp_path):
    out = tmp_path / "a.png"
    for args, msg in [
        (("--mapping", "mercator"), "mapping"),
        (("testdata/apartment.exr", "--mapping", "sphere"), "apartment.exr"),  # 2:1 is no sphere map
        (("--mesh", tmp_path / "none.obj"), "none.obj"),
        (("--mesh", TEAPOT, "--threshold", 0), "threshold"),
    ]:
        r = cli("analyze", *args, "-o", out)
        assert r.returncode == 2, (args, r.stderr)
        assert msg in r.stderr and r.stderr.count("\n") == 1, (args, r.stderr)
        assert not out.exists()
