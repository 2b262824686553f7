import numpy as np
import pytest

import spheremap as sm


def _dirs(n=2000, seed=0):
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("preset", ["blender", "threejs", "skylibs", "filament", "mitsuba", "pbrt"])
def test_latlong_round_trip(preset):
    d = _dirs()
    uv = sm.dir_to_uv(d, "latlong", preset=preset)
    assert ((0 <= uv) & (uv <= 1)).all()
    back, valid = sm.uv_to_dir(uv, "latlong", preset=preset)
    assert valid.all()
    np.testing.assert_allclose(back, d, atol=1e-12)


def test_latlong_default_is_threejs_formula():
    d = _dirs()
    uv = sm.dir_to_uv(d)
    u = (0.5 + np.arctan2(d[:, 2], d[:, 0]) / (2 * np.pi)) % 1.0
    np.testing.assert_allclose(uv[:, 0], u, atol=1e-12)
    np.testing.assert_allclose(uv[:, 1], np.arccos(d[:, 1]) / np.pi, atol=1e-12)


def test_latlong_skylibs_preset_matches_skylibs():
    projections = pytest.importorskip("envmap.projections")
    d = _dirs()
    u, v = projections.world2latlong(d[:, 0], d[:, 1], d[:, 2])
    uv = sm.dir_to_uv(d, "latlong", preset="skylibs")
    du = np.abs(uv[:, 0] - u % 1.0)
    assert np.minimum(du, 1 - du).max() < 1e-12
    np.testing.assert_allclose(uv[:, 1], v, atol=1e-12)


def test_sphere_mapping_uv_is_image_coordinates():
    uv = sm.dir_to_uv([[0, 1.0, 0]], "sphere")  # +Y is above the centre: v < 1/2
    np.testing.assert_allclose(uv, [[0.5, 0.5 - 1 / (2 * np.sqrt(2))]])
    np.testing.assert_allclose(sm.dir_to_uv(_dirs(10), "sphere") * 64, sm.dir_to_pixel(_dirs(10), 64))


@pytest.mark.parametrize("mapping, w, h, tol", [("latlong", 64, 32, 1e-10), ("latlong", 7, 3, 1e-10), ("sphere", 33, 33, 1e-10),
                                             ("angular", 48, 48, 1e-6), ("octahedral", 31, 31, 1e-10)])
def test_solid_angles_sum_to_4pi(mapping, w, h, tol):
    a = sm.texel_solid_angles(mapping, w, h)
    assert a.shape == (h, w)
    assert abs(a.sum() - 4 * np.pi) < tol


@pytest.mark.parametrize("mapping", ["angular", "octahedral"])
def test_round_trips(mapping):
    d = _dirs()
    uv = sm.dir_to_uv(d, mapping)
    back, valid = sm.uv_to_dir(uv, mapping)
    assert valid.all()
    np.testing.assert_allclose(back, d, atol=1e-9)


def test_solid_angle_is_the_local_jacobian():
    """A texel's solid angle matches the area its four corners' directions span (small texels)."""
    n = 256
    for mapping in ["angular", "octahedral", "sphere"]:
        w = sm.texel_solid_angles(mapping, n)
        i, j = 100, 120  # an interior texel
        c = np.array([[i, j], [i + 1, j], [i + 1, j + 1], [i, j + 1]], float) / n
        d, ok = sm.uv_to_dir(c, mapping)
        assert ok.all()
        # Spherical quadrilateral area ~ |(d1-d0) x (d3-d0)| for a small texel.
        approx = np.linalg.norm(np.cross(d[1] - d[0], d[3] - d[0]))
        assert abs(approx - w[j, i]) < 0.02 * w[j, i], mapping


def test_mapping_errors():
    with pytest.raises(ValueError, match="^mapping"):
        sm.dir_to_uv([[1.0, 0, 0]], "cylinder")
    with pytest.raises(ValueError, match="^preset"):
        sm.dir_to_uv([[1.0, 0, 0]], "latlong", preset="maya")
    with pytest.raises(ValueError, match="^height"):
        sm.texel_solid_angles("sphere", 8, 4)
    with pytest.raises(ValueError, match="^preset"):
        sm.dir_to_uv([[1.0, 0, 0]], "octahedral", preset="blender")
