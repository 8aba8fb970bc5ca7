"""Analytic steady axial speed of a screw pair vs its limits and vs a numerical solution."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from snakesim.components.contact import ScrewContactSamples, contact_forces, steady_axial_speed


def test_limits():
    w, r, lam = 2.0, 0.1, 0.3
    assert steady_axial_speed(w, r, lam, 1.0) == 0.0
    assert steady_axial_speed(w, r, lam, 1.0 + 1e-9) == pytest.approx(0.0, abs=1e-9)
    assert steady_axial_speed(w, r, lam, 1e12) == pytest.approx(w * r * np.tan(lam), rel=1e-9)
    u = steady_axial_speed(w, r, lam, np.array([1.5, 3, 10, 100, 1e4]))
    assert np.all(np.diff(u) > 0) and np.all(u < w * r * np.tan(lam))           # monotone, below the nut speed
    assert steady_axial_speed(w, r, lam, 3.0, hand=-1) == -steady_axial_speed(w, r, lam, 3.0)
    assert steady_axial_speed(w, r, lam, 0.5) < 0                                 # k < 1 reverses
    with pytest.raises(ValueError):
        steady_axial_speed(w, r, lam, 0.0)


def screw_pair_speed(omega, lam, k, radius=0.1, mu=0.3, v_eps=0.0, mode="sqrt", t_end=6.0):
    """Rigid body with two counter-rotating opposite-hand screws on z = 0; only axial
    translation free. Contacts: bottom-line samples; penetration set so each screw
    carries half the weight. Integrated with solve_ivp; returns the final axial speed."""
    m, g, kn, rings = 20.0, 9.81, 1e5, 3
    screws = [ScrewContactSamples(radius, 0.3, rings, 4, lam, hand, mount_p=[0, y, 0], phase=-np.pi / 2)
              for hand, y in ((1, 0.15), (-1, -0.15))]
    spins = (omega, -omega)
    d0 = m * g / 2 / rings / kn
    R, p = np.eye(3), np.array([0.0, 0.0, radius - d0])
    normal = np.repeat([[0.0, 0.0, 1.0]], 4 * rings, 0)
    pts = [s.world_points(R, p) for s in screws]
    edir = [s.world_directions(R)[1] for s in screws]

    def rhs(t, x):
        fx = 0.0
        for s, w, P, E in zip(screws, spins, pts, edir):
            v = s.slip_velocity(R, p, [x[0], 0, 0], np.zeros(3), w)
            f, fn = contact_forces(-P[:, 2], normal, v, E, kn, 0.0, mu, k, 0.0, v_eps, mode)
            fx += f[:, 0].sum()
        return [fx / m]

    sol = solve_ivp(rhs, (0, t_end), [0.0], rtol=1e-10, atol=1e-12)
    assert sol.success
    # it has settled: same speed over the last 20 %
    tail = sol.y[0][sol.t > 0.8 * t_end]
    assert np.ptp(tail) < 1e-8
    return sol.y[0, -1]


@pytest.mark.parametrize("lam", [0.1, 0.35, 0.7])
@pytest.mark.parametrize("k", [1.5, 3.0, 10.0])
@pytest.mark.parametrize("omega", [0.5, -3.0])
def test_numerical_screw_pair_reaches_analytic_speed(lam, k, omega):
    u = screw_pair_speed(omega, lam, k)
    assert u == pytest.approx(steady_axial_speed(omega, 0.1, lam, k), rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("mode", ["sqrt", "linear"])
def test_regularisation_and_mu_do_not_change_steady_speed(mode):
    ref = steady_axial_speed(2.0, 0.1, 0.35, 3.0)
    assert screw_pair_speed(2.0, 0.35, 3.0, mu=0.15, v_eps=0.02, mode=mode) == pytest.approx(ref, rel=1e-6)
