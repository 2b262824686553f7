import numpy as np
import pytest

import spheremap as sm
from conftest import cli


def test_version():
    assert sm.__version__.count(".") == 2


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_dir_to_sphere_dtype_follows_input_and_round_trips(dtype):
    rng = np.random.default_rng(0)
    d = rng.normal(size=(1000, 3)).astype(dtype)
    d = d[d[:, 2] > -0.99]
    st = sm.dir_to_sphere(d)
    assert st.dtype == dtype and st.shape == (len(d), 2)
    back, valid = sm.sphere_to_dir(st)
    assert valid.all()
    unit = d / np.linalg.norm(d, axis=1, keepdims=True)
    np.testing.assert_allclose(back, unit, atol=2e-5 if dtype == np.float32 else 1e-9)


def test_pinned_axes_and_singular():
    st = sm.dir_to_sphere(np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1.0]]))
    a = 0.5 + 1 / (2 * np.sqrt(2))
    np.testing.assert_allclose(st[:3], [[a, 0.5], [0.5, a], [0.5, 0.5]])
    assert np.isnan(st[3]).all()
    np.testing.assert_array_equal(sm.dir_to_sphere([[0, 0, -2.0]], singular="center"), [[0.5, 0.5]])


def test_sphere_to_dir_outside_is_invalid_not_garbage():
    dirs, valid = sm.sphere_to_dir([[0.0, 0.0], [1.0, 1.0], [0.5, 0.5], [np.nan, 0.5]])
    assert valid.tolist() == [False, False, True, False]
    assert np.isnan(dirs[~valid]).all()
    np.testing.assert_array_equal(dirs[2], [0, 0, 1])


def test_any_memory_order_and_shape():
    d = np.asfortranarray(np.random.default_rng(1).normal(size=(50, 3)))
    np.testing.assert_array_equal(sm.dir_to_sphere(d), sm.dir_to_sphere(np.ascontiguousarray(d)))
    stacked = sm.dir_to_sphere(d.reshape(5, 10, 3))
    assert stacked.shape == (5, 10, 2)
    assert sm.dir_to_sphere(d[::2]).shape == (25, 2)


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: sm.dir_to_sphere(np.zeros((4, 2))), "dirs"),
        (lambda: sm.dir_to_sphere(np.zeros((4, 3), np.int32)), "dirs"),
        (lambda: sm.dir_to_sphere(np.zeros((4, 3)), singular="edge"), "singular"),
        (lambda: sm.sphere_to_dir(np.zeros((4, 3))), "st"),
        (lambda: sm.sphere_texgen(np.zeros((4, 2)), np.zeros((4, 3)), np.eye(4)), "positions"),
        (lambda: sm.sphere_texgen(np.zeros((4, 3)), np.zeros((5, 3)), np.eye(4)), "normals"),
        (lambda: sm.sphere_texgen(np.zeros((4, 3)), np.zeros((4, 3)), np.eye(3)), "modelview"),
        (lambda: sm.sphere_texgen(np.zeros((4, 3)), np.zeros((4, 3)), np.eye(4), normalize="yes"), "normalize"),
        (lambda: sm.sphere_texgen(np.zeros((4, 3)), np.zeros((4, 3)), np.full((4, 4), np.nan)), "modelview"),
        (lambda: sm.sphere_texgen(np.zeros((4, 3), np.float16), np.zeros((4, 3)), np.eye(4)), "positions"),
        (lambda: sm.matcap_uv(np.zeros((3, 3)), variant="blender"), "variant"),
        (lambda: sm.matcap_uv(np.zeros((3, 3)), np.zeros((2, 3))), "positions"),
        (lambda: sm.sphere_texel_solid_angle(0), "size"),
        (lambda: sm.dir_to_pixel(np.zeros((1, 3)), 8, preset="maya"), "preset"),
        (lambda: sm.reflect(np.zeros((2, 3)), np.zeros((3, 3))), "normal"),
    ],
)
def test_bad_arguments_raise_value_error_naming_them(call, name):
    with pytest.raises(ValueError) as e:
        call()
    assert str(e.value).startswith(name), str(e.value)


def test_texgen_f32_vs_f64_and_input_dtypes():
    rng = np.random.default_rng(2)
    p = rng.normal(size=(10000, 3))
    n = rng.normal(size=(10000, 3))
    mv = np.eye(4)
    mv[:3, :3] = rng.normal(size=(3, 3))
    mv[2, 3] = -10
    a = sm.sphere_texgen(p.astype(np.float32), n.astype(np.float32), mv)
    b = sm.sphere_texgen(p, n, mv)  # float64 in: rounded to f32 first, as GL
    c = sm.sphere_texgen(p.astype(np.float32), n, mv.astype(np.float32))
    assert a.dtype == np.float32 and a.shape == (10000, 2)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)
    ref = sm.sphere_texgen(p, n, mv, precision="f64")
    assert ref.dtype == np.float64
    # r within ~3 degrees of (0,0,-1) is ill-conditioned; elsewhere f32 tracks f64 closely.
    ok = np.hypot(ref[:, 0] - 0.5, ref[:, 1] - 0.5) < 0.4995
    assert np.abs(a - ref)[ok].max() < 1e-5


def test_texgen_positions_with_w_ignore_w_for_view_direction():
    p3 = np.array([[0.2, 0.1, -3.0]], np.float32)
    p4 = np.array([[0.2, 0.1, -3.0, 1.0]], np.float32)
    n = np.array([[0.1, 0.2, 1.0]], np.float32)
    mv = np.eye(4)
    mv[:3, 3] = [0.5, 0, 0]
    np.testing.assert_array_equal(sm.sphere_texgen(p3, n, mv), sm.sphere_texgen(p4, n, mv))
    # Scaling (x,y,z,w) by a negative factor flips eye.xyz: GL does not divide by w.
    p4n = -2 * p4
    assert not np.allclose(sm.sphere_texgen(p4n, n, mv), sm.sphere_texgen(p4, n, mv))


def test_texgen_large_input_is_parallel_and_consistent():
    rng = np.random.default_rng(3)
    p = rng.normal(size=(200_001, 4)).astype(np.float32)
    n = rng.normal(size=(200_001, 3)).astype(np.float32)
    mv = np.eye(4)
    mv[2, 3] = -5
    whole = sm.sphere_texgen(p, n, mv)
    parts = np.concatenate([sm.sphere_texgen(p[i:i + 777], n[i:i + 777], mv) for i in range(0, 200_001, 777)])
    np.testing.assert_array_equal(whole, parts)


def test_reflect():
    r = sm.reflect([[0, 0, -1.0]], [[0, 0, 1.0]])
    np.testing.assert_array_equal(r, [[0, 0, 1]])
    r = sm.reflect(np.array([[1, -1, 0]], np.float32), np.array([0, 1, 0], np.float32))
    assert r.dtype == np.float32
    np.testing.assert_array_equal(r, [[1, 1, 0]])


def test_solid_angles():
    w = sm.sphere_texel_solid_angle(256)
    assert w.shape == (256, 256)
    assert abs(w.sum() - 4 * np.pi) < 1e-9
    assert w[128, 128] == 16 / 256**2


class TestMatcap:
    def test_classic(self):
        uv = sm.matcap_uv([[0, 0, 1.0], [1, 0, 0], [0, 2, 0]])
        np.testing.assert_allclose(uv, [[0.5, 0.5], [1, 0.5], [0.5, 1]])

    def test_threejs_on_axis_is_classic_at_0495(self):
        n = np.random.default_rng(4).normal(size=(100, 3))
        a = sm.matcap_uv(n, np.tile([0, 0, -5.0], (100, 1)), variant="threejs")
        b = sm.matcap_uv(n, scale=0.495)
        np.testing.assert_allclose(a, b, atol=1e-12)

    def test_perspective_centre_and_rim(self):
        rng = np.random.default_rng(5)
        p = rng.normal(size=(500, 3)) + [0, 0, -6]
        d = p / np.linalg.norm(p, axis=1, keepdims=True)
        centre = sm.matcap_uv(-d, p, variant="perspective")
        np.testing.assert_allclose(centre, 0.5, atol=1e-12)
        # Any normal perpendicular to the view ray lands on the rim.
        t = np.cross(d, rng.normal(size=(500, 3)))
        rim = sm.matcap_uv(t, p, variant="perspective")
        np.testing.assert_allclose(np.hypot(rim[:, 0] - 0.5, rim[:, 1] - 0.5), 0.5, atol=1e-12)
        # The classic lookup does not (that is what the variant corrects).
        classic = sm.matcap_uv(t, p, variant="classic")
        assert np.abs(np.hypot(classic[:, 0] - 0.5, classic[:, 1] - 0.5) - 0.5).max() > 0.01
        # On the optical axis it is the classic lookup.
        n = rng.normal(size=(50, 3))
        np.testing.assert_allclose(sm.matcap_uv(n, np.tile([0, 0, -3.0], (50, 1)), variant="perspective"), sm.matcap_uv(n), atol=1e-12)

    def test_threejs_also_maps_silhouettes_to_its_rim(self):
        p = np.array([[2.0, 1.0, -5.0]])
        d = p / np.linalg.norm(p)
        t = np.cross(d, [[0.3, 1, 0.2]])
        uv = sm.matcap_uv(t, p, variant="threejs")
        assert abs(np.hypot(uv[0, 0] - 0.5, uv[0, 1] - 0.5) - 0.495) < 1e-12


class TestPresets:
    def test_listing(self):
        ps = sm.presets()
        assert {"gl", "gl-upload", "d3d", "skylibs", "blender-mirrorball", "mirror-ball-photo"} <= set(ps)
        np.testing.assert_array_equal(ps["gl"].frame, np.eye(3))

    def test_pixels_round_trip(self):
        rng = np.random.default_rng(6)
        d = rng.normal(size=(200, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        for name in sm.presets():
            xy = sm.dir_to_pixel(d, 512, preset=name)
            ok = ~np.isnan(xy[:, 0])
            back, valid = sm.pixel_to_dir(xy[ok], 512, preset=name)
            assert valid.all()
            np.testing.assert_allclose(back, d[ok], atol=1e-6)

    def test_skylibs_preset_matches_skylibs(self):
        projections = pytest.importorskip("envmap.projections")
        rng = np.random.default_rng(7)
        d = rng.normal(size=(500, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        d = d[d[:, 2] < 0.99]  # skylibs' rim is +Z
        u, v = projections.world2sphere(d[:, 0], d[:, 1], d[:, 2])
        xy = sm.dir_to_pixel(d, 1000, preset="skylibs")
        np.testing.assert_allclose(xy[:, 0], u * 1000, atol=1e-6)
        np.testing.assert_allclose(xy[:, 1], v * 1000, atol=1e-6)


def test_cli_console_script_is_the_rust_cli(tmp_path):
    out = cli("--version")
    assert out.returncode == 0 and out.stdout.strip() == f"spheremap {sm.__version__}"
    bad = cli("texgen", str(tmp_path / "none.obj"), "--modelview", "identity", "-o", str(tmp_path / "x.csv"))
    assert bad.returncode == 2
    assert bad.stderr.count("\n") == 1 and "none.obj" in bad.stderr
    assert not (tmp_path / "x.csv").exists()


def test_texgen_out_buffer():
    rng = np.random.default_rng(8)
    p = rng.normal(size=(1000, 3)).astype(np.float32)
    n = rng.normal(size=(1000, 3)).astype(np.float32)
    mv = np.eye(4)
    mv[2, 3] = -4
    buf = np.empty((1000, 2), np.float32)
    got = sm.sphere_texgen(p, n, mv, out=buf)
    assert got is buf
    np.testing.assert_array_equal(buf, sm.sphere_texgen(p, n, mv))
    for bad in (np.empty((999, 2), np.float32), np.empty((1000, 2), np.float64), np.empty((2, 1000), np.float32).T,
                np.empty((1000, 2), np.float32)[::1, ::-1], [[0, 0]] * 1000):
        with pytest.raises(ValueError, match="^out"):
            sm.sphere_texgen(p, n, mv, out=bad)
    ro = np.empty((1000, 2), np.float32)
    ro.flags.writeable = False
    with pytest.raises(ValueError, match="^out"):
        sm.sphere_texgen(p, n, mv, out=ro)


def test_names_and_limits_are_the_cores(tmp_path):
    # The lists of names are the core's, and the core's parser (with its aliases) checks them.
    assert sm.FILTERS == ("box", "tent", "gaussian") and sm.TAPS == ("bilinear", "bicubic")
    assert "hcross" in sm.CUBE_LAYOUTS and sm.PHOTO_FILLS == ("none", "smooth", "mean")
    img = np.ones((8, 16, 3), np.float32)
    tent = sm.convert(img, "latlong", "sphere", size=8, filter="tent")
    np.testing.assert_array_equal(sm.convert(img, "latlong", "sphere", size=8, filter="triangle"), tent)
    sm.convert(img, "latlong", "sphere", size=8, filter="gauss")
    for kw, prefix in [(dict(filter="lanczos"), "filter: "), (dict(filter=3), "filter: "),
                       (dict(outside="grey"), "outside: "), (dict(precision="f16"), "precision: "),
                       (dict(size=40000), "size: 40000 is out of range 1..=32768")]:
        with pytest.raises(ValueError, match="^" + prefix):
            sm.convert(img, "latlong", "sphere", **kw)
    # One size limit for analysis, in the core: the CLI says the same.
    with pytest.raises(ValueError, match="^size: 9000 is out of range 1..=8192"):
        sm.analyze(mapping="sphere", size=9000)
    r = cli("analyze", "--mapping", "sphere", "--size", 9000, "--output", tmp_path / "a.png")
    assert r.returncode == 2 and "size: 9000 is out of range 1..=8192" in r.stderr, r.stderr
    assert not (tmp_path / "a.png").exists()
    assert sm.analyze(mapping="latlong", size=8)["solid_angle"].shape == (8, 16)
    rim = sm.dir_to_sphere(np.array([[0.0, 0.0, -1.0]]), singular="centre")
    np.testing.assert_array_equal(rim, sm.dir_to_sphere(np.array([[0.0, 0.0, -1.0]]), singular="center"))
