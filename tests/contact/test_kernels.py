"""Contact kernels against hand-computed forces (eqs. 1, 2, 6) and their properties."""

import numpy as np
import pytest
from scipy.optimize import brentq

from snakesim.components.contact import (PointContactParams, anisotropic_friction, contact_forces,
                                         contact_forces_numba, isotropic_friction, normal_force, slip_direction,
                                         tangential_velocity)
from snakesim.components.materials import Material

Z = np.array([[0.0, 0.0, 1.0]])


def test_normal_force_eq2_by_hand():
    # k d + c ḋ = 1e4·0.01 + 100·0.5 = 150 N, moving into the ground at 0.5 m/s
    fn = normal_force([0.01], Z, [[0.0, 0.0, -0.5]], 1e4, 100.0)
    assert fn == pytest.approx([150.0])
    force, fn2 = contact_forces([0.01], Z, [[0.0, 0.0, -0.5]], Z, 1e4, 100.0, mu=0.3)
    np.testing.assert_allclose(force, [[0.0, 0.0, 150.0]])


def test_normal_force_never_pulls():
    # separating at 2 m/s: 1e4·0.01 − 100·2 = −100 N -> clamped to 0, not an attraction
    assert normal_force([0.01], Z, [[0, 0, 2.0]], 1e4, 100.0) == pytest.approx([0.0])
    # out of contact (d ≤ 0) even when approaching fast
    assert normal_force([-0.001, 0.0], np.repeat(Z, 2, 0), [[0, 0, -5.0]] * 2, 1e4, 100.0) == pytest.approx([0, 0])
    rng = np.random.default_rng(1)
    n = rng.normal(size=(500, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    f, fn = contact_forces(rng.normal(0, 0.01, 500), n, rng.normal(size=(500, 3)), rng.normal(size=(500, 3)),
                           1e4, 500.0, 0.4, 2.0, 0.01, 1e-3)
    assert np.all(fn >= 0) and np.all(np.einsum("ij,ij->i", f, n) >= -1e-12)


def test_isotropic_eq1_3_4_5():
    # v_t = (3, 4, 0) -> v̂_t = (0.6, 0.8, 0); F_n = 10 N, μ = 0.5: F_t = −5·(0.6, 0.8) = (−3, −4)
    ft = isotropic_friction([10.0], [[3.0, 4.0, 0.0]], 0.5)
    np.testing.assert_allclose(ft, [[-3.0, -4.0, 0.0]])
    # the normal component of the velocity does not enter
    vt = tangential_velocity([[3.0, 4.0, 7.0]], Z)
    np.testing.assert_allclose(isotropic_friction([10.0], vt, 0.5), [[-3.0, -4.0, 0.0]])


def test_anisotropic_eq6_by_hand():
    # ê_v = x, ‖e_v‖ = 3: v̂_t·ê_v = 0.6, skew = (0.6 + 2·0.6, 0.8) = (1.8, 0.8); F = −5·skew
    ft = anisotropic_friction([10.0], [[3.0, 4.0, 0.0]], [[1.0, 0.0, 0.0]], Z, mu=0.5, ev_a=3.0)
    np.testing.assert_allclose(ft, [[-9.0, -4.0, 0.0]])
    # ‖e_v‖ = a + b F_n = 1 + 0.2·10 = 3 and a tilted ê_v (projected onto the tangent plane)
    ft = anisotropic_friction([10.0], [[3.0, 4.0, 0.0]], [[2.0, 0.0, 5.0]], Z, mu=0.5, ev_a=1.0, ev_b=0.2)
    np.testing.assert_allclose(ft, [[-9.0, -4.0, 0.0]])
    # full kernel: d = 0.001, k = 1e4 -> F_n = 10 N; slip (3, 4) m/s
    f, fn = contact_forces([0.001], Z, [[3.0, 4.0, 0.0]], [[1.0, 0, 0]], 1e4, 0.0, 0.5, 3.0)
    np.testing.assert_allclose(f, [[-9.0, -4.0, 10.0]])


def test_isotropic_limit_equals_eq1():
    rng = np.random.default_rng(2)
    fn, vt, e = rng.uniform(0, 50, 100), rng.normal(size=(100, 3)), rng.normal(size=(100, 3))
    vt[:, 2] = 0.0
    n = np.repeat(Z, 100, 0)
    np.testing.assert_allclose(anisotropic_friction(fn, vt, e, n, 0.3, 1.0, 0.0, 1e-3),
                               isotropic_friction(fn, vt, 0.3, 1e-3), atol=1e-13)


def test_skewed_force_tilts_toward_ev():
    rng = np.random.default_rng(3)
    vt = rng.normal(size=(200, 3))
    vt[:, 2] = 0
    e = np.repeat([[1.0, 0, 0]], 200, 0)
    for k, closer in ((4.0, True), (0.5, False)):
        ft = anisotropic_friction(np.full(200, 10.0), vt, e, np.repeat(Z, 200, 0), 0.3, k)
        cos_f = np.abs(ft[:, 0]) / np.linalg.norm(ft, axis=1)
        cos_v = np.abs(vt[:, 0]) / np.linalg.norm(vt, axis=1)
        assert np.all(cos_f >= cos_v - 1e-12) if closer else np.all(cos_f <= cos_v + 1e-12)
        # still dissipative: F·v ≤ 0
        assert np.all(np.einsum("ij,ij->i", ft, vt) <= 1e-12)


@pytest.mark.parametrize("mode", ["sqrt", "linear"])
def test_regularised_friction_continuous_at_zero_slip(mode):
    v_eps, mu, fn = 1e-3, 0.3, 10.0
    assert np.all(slip_direction(np.zeros((1, 3)), v_eps, mode) == 0.0)
    for d in (1e-9, 1e-7, 1e-5):
        vt = np.array([[d, 0, 0], [-d, 0, 0]])
        ft = isotropic_friction([fn, fn], vt, mu, v_eps, mode)
        # viscous slope μF_n/v_ε below v_ε: jump across zero is 2 d μ F_n / v_ε, → 0 with d
        assert abs(ft[0, 0] - ft[1, 0]) <= 2 * d * mu * fn / v_eps * (1 + 1e-9)
    # unregularised (v_ε = 0): the classic ±μF_n jump
    ft = isotropic_friction([fn, fn], [[1e-12, 0, 0], [-1e-12, 0, 0]], mu, 0.0, mode)
    assert ft[0, 0] - ft[1, 0] == pytest.approx(-2 * mu * fn)


@pytest.mark.parametrize("theta", [0.05, 0.1, 0.2])
def test_creep_speed_bound_on_slope(theta):
    """Resting on a slope θ: creep v solves μ F_n ‖s(v)‖ = W sin θ (F_n = W cos θ)."""
    mu, v_eps, W = 0.5, 1e-3, 100.0
    r = np.tan(theta) / mu

    def residual(v, mode):
        return mu * W * np.cos(theta) * np.linalg.norm(isotropic_friction([1.0], [[v, 0, 0]], 1.0, v_eps, mode)) - W * np.sin(theta)

    v_lin = brentq(residual, 0.0, 1.0, args=("linear",), xtol=1e-15)
    v_sqrt = brentq(residual, 0.0, 1.0, args=("sqrt",), xtol=1e-15)
    assert v_lin == pytest.approx(v_eps * np.tan(theta) / mu, rel=1e-9)           # the bound, attained
    assert v_sqrt == pytest.approx(v_eps * r / np.sqrt(1 - r * r), rel=1e-9)
    assert v_sqrt <= v_eps * np.tan(theta) / mu / np.sqrt(1 - r * r) * (1 + 1e-12)


def test_material_rejects_nonpositive_ev_on_working_range():
    PointContactParams(material=Material(mu=0.25, ev_a=1.8, ev_b=0.025), fn_max=100)
    with pytest.raises(ValueError, match="falls to"):
        PointContactParams(material=Material(mu=0.25, ev_a=1.0, ev_b=-0.02), fn_max=100)   # 1 − 2 = −1 at 100 N
    with pytest.raises(ValueError, match="ev_a = 0 must be > 0"):
        Material(ev_a=0.0)
    # the kernel clamps an out-of-range load at ev_floor rather than reversing friction
    ft = anisotropic_friction([1000.0], [[1.0, 0, 0]], [[1.0, 0, 0]], Z, 0.3, 1.0, -0.01)
    assert ft[0, 0] < 0


@pytest.mark.parametrize("mode", ["sqrt", "linear"])
def test_numba_matches_numpy(mode):
    rng = np.random.default_rng(4)
    n = 300
    normal = rng.normal(size=(n, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    vel = rng.normal(size=(n, 3))
    vel[:10] = 0.0                                   # at rest
    vel[10:20] = normal[10:20] * 0.3                 # pure normal motion, no slip
    e = rng.normal(size=(n, 3))
    e[20:25] = normal[20:25]                         # degenerate anisotropy axis
    depth = rng.normal(0, 0.01, n)
    for v_eps in (0.0, 1e-3):
        args = (depth, normal, vel, e, 1e4, 300.0, 0.35, 1.7, 0.02, v_eps, mode)
        f0, fn0 = contact_forces(*args)
        f1, fn1 = contact_forces_numba(*args)
        np.testing.assert_allclose(f1, f0, rtol=1e-12, atol=1e-12)   # forces up to ~5 kN here
        np.testing.assert_allclose(fn1, fn0, rtol=1e-12, atol=1e-12)
