"""The numba configuration maps (lie_kernels.py) against Pinocchio's: integrate (free-flyer, revolute,
continuous joints) and the free-flyer's stage correction Jlog6(exp6(u)), the inverse of Jexp6(u)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from snakesim.components.multibody import Multibody
from snakesim.components.multibody import lie_kernels as lk
from snakesim.framework import Harness


@pytest.fixture(scope="module")
def model():
    h = Harness(Multibody, {"design": "eels-1.0", "modules": 3})
    return h.c.dyn.model, h.c


def random_q(m, rng):
    """A configuration with finite angles (pin.randomConfiguration gives ±inf for unlimited joints)."""
    q = pin.neutral(m)
    for j in list(m.joints)[1:]:
        a = j.idx_q
        if j.nq == 7:
            q[a:a + 3] = rng.normal(size=3)
            quat = rng.normal(size=4)
            q[a + 3:a + 7] = quat / np.linalg.norm(quat)
        elif j.nq == 2:
            th = rng.uniform(-np.pi, np.pi)
            q[a:a + 2] = np.cos(th), np.sin(th)
        elif j.nq == 1:
            q[a] = rng.uniform(-2.0, 2.0)
    return q


@pytest.mark.parametrize("scale", [1e-9, 1e-5, 1e-2, 0.5, 2.0])
def test_integrate_equals_pinocchio(model, scale):
    m, _ = model
    layout = lk.joint_layout(m)
    assert layout is not None and set(layout[0]) == {lk.FREE_FLYER, lk.ADD, lk.SO2}
    rng = np.random.default_rng(int(1e3 * scale) + 7)
    out = np.empty(m.nq)
    for _ in range(50):
        q = random_q(m, rng)
        dv = rng.normal(size=m.nv) * scale
        lk.integrate_q(q, dv, out, *layout)
        # the same formulas in another order of operations: a few ulps on unit-size coordinates
        np.testing.assert_allclose(out, pin.integrate(m, q, dv), rtol=0, atol=1e-14)


@pytest.mark.parametrize("theta", [1e-7, 1e-5, 2e-4, 1e-3, 1e-2, 0.3, 1.5, 3.0])
def test_dexp_inv_inverts_jexp6(theta):
    """k ← Jlog6(exp6(u)) k is Jexp6(u)⁻¹ k for |ω| = θ < π. Above ε^¼ the closed form's β and β̇ lose
    ~ε/θ² to cancellation (below, the series is exact to round-off): the tolerance. Pinocchio's own
    Jlog6(exp6(u)) recovers θ through log3 of the rotation, which loses more at small θ (7e-6 at
    θ = 2e-4), so it is compared only where it is accurate."""
    rng = np.random.default_rng(int(theta * 1e7) % 1000)
    tol = 2e-13 + (4 * np.finfo(float).eps / theta ** 2 if theta >= lk.SMALL else 0.0)
    for _ in range(50):
        w = rng.normal(size=3)
        u = np.r_[rng.normal(size=3), theta * w / np.linalg.norm(w)]
        k = rng.normal(size=6)
        got = k.copy()
        lk.dexp_inv6(u, got)
        assert np.abs(pin.Jexp6(u) @ got - k).max() <= tol * np.abs(k).max()
        if theta <= 1e-5 or theta >= 0.3:
            ref = pin.Jlog6(pin.exp6(u)) @ k
            assert np.abs(got - ref).max() <= 1e-13 * np.abs(ref).max()


def test_multibody_maps_use_the_kernels_and_agree_with_pinocchio(model):
    """Multibody.integrate / dexp_inv (and their bound forms) give pin.integrate's q and the v add, and
    Jlog6(exp6(u)) on the free-flyer's six rates, leaving the other rates alone."""
    m, mb = model
    rng = np.random.default_rng(3)
    nq, nv = m.nq, m.nv
    x = np.r_[random_q(m, rng), rng.normal(size=nv)]
    dx = rng.normal(size=2 * nv) * 0.01
    out, bound_out = np.empty_like(x), np.empty_like(x)
    mb.integrate(x, dx, out)
    mb.bind_integrate(x, dx, bound_out)()
    np.testing.assert_array_equal(out, bound_out)
    np.testing.assert_allclose(out[:nq], pin.integrate(m, x[:nq], dx[:nv]), rtol=0, atol=1e-14)
    np.testing.assert_array_equal(out[nq:], x[nq:] + dx[nv:])
    k = rng.normal(size=2 * nv)
    k1, k2 = k.copy(), k.copy()
    mb.dexp_inv(x, dx, k1)
    mb.bind_dexp_inv(x, dx, k2)()
    np.testing.assert_array_equal(k1, k2)
    np.testing.assert_allclose(pin.Jexp6(dx[:6]) @ k1[:6], k[:6], rtol=0, atol=1e-10)
    np.testing.assert_array_equal(k1[6:], k[6:])
