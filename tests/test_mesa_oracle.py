"""spheremap.sphere_texgen against a real OpenGL (Mesa via OSMesa), in all three normal modes.

Goal: max |difference| <= 2e-5 on well-conditioned cases, and the identical NaN
pattern with singular="nan". "Well-conditioned" is defined in `_well_conditioned` below.
"""

import numpy as np
import pytest

import spheremap as sm

MODES = ["on", "off", "rescale"]


def _random_modelviews(rng, count):
    """Rotations, uniform and non-uniform scales, shears, translations, a few projective bottom
    rows, and exactly length-preserving ones (which Mesa treats specially for RESCALE)."""
    out = []
    for k in range(count):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        if np.linalg.det(q) < 0:
            q[:, 0] *= -1
        m = np.eye(4)
        kind = k % 5
        if kind == 0:  # rigid
            m[:3, :3] = q
        elif kind == 1:  # uniform scale
            m[:3, :3] = q * rng.uniform(0.2, 5.0)
        elif kind == 2:  # non-uniform scale
            m[:3, :3] = q @ np.diag(rng.uniform(0.2, 4.0, 3))
        elif kind == 3:  # general (shear)
            m[:3, :3] = rng.normal(size=(3, 3))
        else:  # projective bottom row
            m[:3, :3] = q @ np.diag(rng.uniform(0.5, 2.0, 3))
            m[3, :3] = rng.normal(scale=0.1, size=3)
        m[:3, 3] = rng.normal(scale=2.0, size=3) + [0, 0, -8]
        out.append(m)
    return out


def _cases(rng, per_matrix=400, matrices=10):
    for mv in _random_modelviews(rng, matrices):
        p = np.c_[rng.normal(scale=2.0, size=(per_matrix, 3)), np.ones(per_matrix)]
        # Some vertices with w != 1, some negative w (GL ignores w for u).
        w = rng.choice([1.0, 1.0, 0.5, 2.0, -1.0, -0.7], size=per_matrix)
        p[:, 3] = w
        n = rng.normal(size=(per_matrix, 3)) * rng.uniform(0.3, 3.0, size=(per_matrix, 1))
        yield mv, p.astype(np.float32), n.astype(np.float32)


def _well_conditioned(mv, p, n, mode):
    """Cases where the f32 result is insensitive to rounding: the modelview well conditioned,
    the vertex not near the eye, the transformed normal not long (mode "off"), and r not within
    ~3 degrees of (0,0,-1), where m -> 0 and s,t are ill-conditioned."""
    st = sm.sphere_texgen(p, n, mv, normalize=mode, precision="f64")
    # Recompute r in f64 to get m.
    inv = np.linalg.inv(mv)
    e = p.astype(np.float64) @ mv.T
    u = e[:, :3] / np.linalg.norm(e[:, :3], axis=1, keepdims=True)
    ne = n.astype(np.float64) @ inv[:3, :3]
    if mode == "on":
        ne = ne / np.linalg.norm(ne, axis=1, keepdims=True)
    r = u - 2 * np.sum(ne * u, axis=1, keepdims=True) * ne
    m = 2 * np.sqrt(r[:, 0] ** 2 + r[:, 1] ** 2 + (r[:, 2] + 1) ** 2)
    ok = (np.linalg.cond(mv) < 1e3) & (np.linalg.norm(e[:, :3], axis=1) > 1e-2) & (m > 0.1)
    if mode == "off":
        ok &= np.linalg.norm(ne, axis=1) < 4.0
    if mode == "rescale":
        ok &= np.linalg.norm(ne, axis=1) * _rescale(mv) < 4.0
    return ok & np.all(np.isfinite(st), axis=1)


def _rescale(mv):
    inv = np.linalg.inv(mv)
    return 1.0 / np.sqrt(np.sum(inv[2, :3] ** 2))


@pytest.mark.parametrize("mode", MODES)
def test_random_cases_match_mesa(mesa, mode):
    rng = np.random.default_rng({"on": 1, "off": 2, "rescale": 3}[mode])
    worst, total, good = 0.0, 0, 0
    for mv, p, n in _cases(rng):
        ref = mesa.mesa_sphere_texgen(p, n, mv, mode)
        got = sm.sphere_texgen(p, n, mv, normalize=mode, singular="nan")
        np.testing.assert_array_equal(np.isnan(got), np.isnan(ref))
        ok = _well_conditioned(mv, p, n, mode)
        d = np.abs(got - ref)[ok]
        worst = max(worst, float(d.max()))
        total += len(p)
        good += int(ok.sum())
        # Everything, conditioned or not, stays close to Mesa in the large.
        assert np.nanmax(np.abs(got - ref)) < 5e-3
    print(f"\n[mesa {mode}] {total} cases, {good} well-conditioned, max |diff| = {worst:.3g}")
    assert good > 0.6 * total  # long unnormalized normals are excluded in off/rescale
    assert worst <= 2e-5


def _degenerate_cases():
    """Hand-made cases where GL produces NaN or special values."""
    I = np.eye(4)
    cases = []
    # r = (0,0,-1) exactly: the normal perpendicular to the view ray on the axis.
    for nrm in ([1, 0, 0], [0, 1, 0], [0.6, 0.8, 0], [3, 0, 0]):
        cases.append((I, [0, 0, -5, 1], nrm))
    # Zero normal.
    cases.append((I, [0.3, 0.2, -4, 1], [0, 0, 0]))
    # Eye position at the origin (vertex at the eye), and w ignored for u.
    cases.append((I, [0, 0, 0, 1], [0, 0, 1]))
    cases.append((I, [0, 0, -3, -2], [0, 0, 1]))
    # Translation bringing the vertex to the eye.
    t = np.eye(4)
    t[:3, 3] = [-1, -2, -3]
    cases.append((t, [1, 2, 3, 1], [0, 1, 0]))
    # Reflection straight back (centre).
    cases.append((I, [0, 0, -5, 1], [0, 0, 1]))
    # Singular modelview: Mesa uses the identity as the inverse.
    s = np.diag([1.0, 0.0, 1.0, 1.0])
    s[:3, 3] = [0, 0, -5]
    cases.append((s, [0.5, 0.5, 0.5, 1], [0.3, 0.4, 0.5]))
    cases.append((np.zeros((4, 4)), [0.5, 0.5, 0.5, 1], [0.3, 0.4, 0.5]))
    return cases


@pytest.mark.parametrize("mode", MODES)
def test_degenerate_cases_match_mesa(mesa, mode):
    for mv, p, n in _degenerate_cases():
        p = np.array([p], np.float32)
        n = np.array([n], np.float32)
        got = sm.sphere_texgen(p, n, mv, normalize=mode, singular="nan")
        if float(p[0] @ np.asarray(mv)[3]) == 0.0:
            # Eye w = 0 (the all-zero modelview): GL clips the point whatever the projection,
            # so Mesa has nothing to compare; every eye position is the origin: NaN.
            assert np.isnan(got).all()
            continue
        ref = mesa.mesa_sphere_texgen(p, n, mv, mode)
        np.testing.assert_array_equal(np.isnan(got), np.isnan(ref), err_msg=f"{mv.tolist()} {p} {n} {mode}")
        fin = ~np.isnan(ref)
        np.testing.assert_allclose(got[fin], ref[fin], atol=2e-5, err_msg=f"{mv.tolist()} {p} {n} {mode}")


def test_center_mode_replaces_mesa_nans(mesa):
    """singular="center" gives (1/2, 1/2) where r = (0,0,-1) (legacy Mesa / Cycles) and agrees
    with Mesa elsewhere."""
    I = np.eye(4)
    p = np.array([[0, 0, -5, 1], [0.3, 0.1, -5, 1]], np.float32)
    n = np.array([[1, 0, 0], [0.2, 0.1, 1]], np.float32)
    ref = mesa.mesa_sphere_texgen(p, n, I, "on")
    got = sm.sphere_texgen(p, n, I, normalize="on", singular="center")
    assert np.isnan(ref[0]).all()
    np.testing.assert_array_equal(got[0], [0.5, 0.5])
    np.testing.assert_allclose(got[1], ref[1], atol=2e-5)
