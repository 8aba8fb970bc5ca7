"""rosenbrock_w and the Jacobian declarations it assembles (framework/linearization.py), on the
linear oscillator ẍ = −ω²x: measured orders with and without a declared Jacobian (a W-method's
order does not depend on it), the stability function with the exact one, stiffness, and the
structured solve against a dense one."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from pydantic import ValidationError

from snakesim.framework.integrators.rosenbrock_w import ROS34PW2, RosenbrockW
from snakesim.framework.linearization import Linearization, Mechanical
from snakesim.framework.session import load_session


def _declared(base):
    """conftest's oscillator (ẍ = −ω² x, declares nothing) declaring its mechanical block: M = 1,
    ∂Q/∂x = −ω², ∂Q/∂v = 0."""

    class DeclaredOscillator(base):
        type_name = "test_declared_oscillator"

        def mechanical_jacobian(self, t, x, u, y, lin):
            return Mechanical(M=np.eye(1), Gq=np.array([[-self.p.omega ** 2]]), Gv=np.zeros((1, 1)))

    return DeclaredOscillator


@pytest.fixture(scope="module")
def reg(registry):
    """conftest's registry (its oscillator is "test_oscillator") plus the declaring twin."""
    registry.add_component(_declared(registry.component("test_oscillator")))
    return registry


def oscillator(tmp_path, reg, kind, dt, duration, omega=1.0, params=None):
    path = tmp_path / "osc.yaml"
    path.write_text(f"""
sim:
  duration: {duration!r}
  dt: {dt!r}
  integrator: {{name: rosenbrock_w, params: {json.dumps(params or {})}}}
components:
  osc: {{type: {kind}, params: {{omega: {omega!r}, x0: 1.0, v0: 0.0}}}}
record: [osc.x, osc.v, osc.energy]
""")
    s = load_session(path, registry=reg)
    r = s.run()
    return s, r


def max_error(r, omega):
    t = r["t"]
    return float(np.max(np.hypot(r["osc.x"] - np.cos(omega * t), (r["osc.v"] + omega * np.sin(omega * t)) / omega)))


@pytest.mark.parametrize("kind", ["test_oscillator", "test_declared_oscillator"])
@pytest.mark.parametrize("method, order, dts", [("ros34pw2", 3, (0.2, 0.1, 0.05, 0.025)),
                                                ("ros2", 2, (0.1, 0.05, 0.025, 0.0125))])
def test_order_does_not_depend_on_the_declared_jacobian(tmp_path, reg, kind, method, order, dts):
    """Undeclared, J = 0 and the method is explicit; declared, J is exact: the measured order is
    the method's either way (W-method order conditions hold for any J)."""
    omega, T = 1.0, 10.0
    errors = [max_error(oscillator(tmp_path, reg, kind, dt, T, omega, {"method": method})[1], omega) for dt in dts]
    slope = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    assert abs(slope - order) < 0.3, (slope, errors)


def _R_ros2(z):
    g = 1 + 1 / math.sqrt(2)
    w = 1 / (1 - g * z)
    return 1 + 1.5 * z * w + 0.5 * z * w * (1 + z * w - 2 * w)


def _R_ros34pw2(z):
    """Stability function of ROS34PW2 with the exact Jacobian: R(z) = 1 + z bᵀ(I − z(α + Γ))⁻¹ 1, from
    the U form's coefficients (a = αΓ⁻¹, m = bᵀΓ⁻¹, c = diag(1/γ) − Γ⁻¹)."""
    gamma, a, c, m = ROS34PW2
    Gi = np.diag(np.full(4, 1 / gamma)) - c
    G = np.linalg.inv(Gi)
    alpha, b = a @ G, m @ G
    return 1 + z * b @ np.linalg.solve(np.eye(4) - z * (alpha + G), np.ones(4))


@pytest.mark.parametrize("method, R", [("ros2", _R_ros2), ("ros34pw2", _R_ros34pw2)])
def test_energy_follows_the_stability_function_with_the_declared_jacobian(tmp_path, reg, method, R):
    """On ẋ = A x (A skew in (ωx, v)) one step multiplies the state by R(hA): the energy after n
    steps is E0·|R(iωh)|^(2n) exactly, so the solve uses J as declared, and the method is the
    tableau's."""
    omega, dt, T = 2 * math.pi, 0.05, 50.0
    _, r = oscillator(tmp_path, reg, "test_declared_oscillator", dt, T, omega, {"method": method})
    E = r["osc.energy"]
    amp = abs(R(1j * omega * dt))
    assert amp < 1.0
    np.testing.assert_allclose(E, E[0] * amp ** (2 * np.arange(E.size)), rtol=1e-9)
    assert 1 - E[-1] / E[0] > 0.01


@pytest.mark.filterwarnings("ignore:overflow encountered")
def test_declared_stiffness_is_integrated_implicitly(tmp_path, reg):
    """ω = 1e3 at h = 10 ms (hω = 10, beyond every explicit method's limit, RK4's is 2.8): with the
    declared Jacobian the energy only decays (L-stable: |R(iy)| < 1); undeclared, the same method is
    explicit and the run blows up and stops."""
    omega, dt = 1e3, 0.01
    _, r = oscillator(tmp_path, reg, "test_declared_oscillator", dt, 1.0, omega)
    assert r.summary["completed"]
    E = r["osc.energy"]
    assert np.all(np.diff(E) <= 1e-12 * E[0])
    _, bad = oscillator(tmp_path, reg, "test_oscillator", dt, 1.0, omega)
    assert not bad.summary["completed"]


def test_structured_solve_equals_the_dense_one(tmp_path, reg):
    """(I − cJ)⁻¹ r by the reduced (nv × nv) solve equals the dense solve of the assembled J."""
    s, _ = oscillator(tmp_path, reg, "test_declared_oscillator", 0.01, 0.05, 3.0)
    lin = Linearization(s.plan)
    s.plan.f(0.0, s.plan.X)
    lin.assemble(0.0)
    J = lin.dense()
    np.testing.assert_allclose(J, [[0.0, 1.0], [-9.0, 0.0]])
    lin.factor(0.7)
    r, out = np.array([0.3, -1.1]), np.zeros(2)
    lin.solve(r, out)
    np.testing.assert_allclose(out, np.linalg.solve(np.eye(2) - 0.7 * J, r), rtol=1e-13)


@pytest.mark.parametrize("params, key", [({"method": "ros3"}, "method"), ({"jacobian_every": 0}, "jacobian_every")])
def test_bad_params_name_the_key(params, key):
    with pytest.raises(ValidationError, match=key):
        RosenbrockW(params)
