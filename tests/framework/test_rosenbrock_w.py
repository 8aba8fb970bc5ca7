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

from snakesim.framework import Component, Input, Output, Params
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


def _fixed(params):
    """The method's own fixed-step properties (order, stability function, where J is assembled) are measured at
    fixed steps: step_control: fixed unless a test says otherwise."""
    return {"step_control": "fixed", **(params or {})}


def oscillator(tmp_path, reg, kind, dt, duration, omega=1.0, params=None):
    path = tmp_path / "osc.yaml"
    path.write_text(f"""
sim:
  duration: {duration!r}
  dt: {dt!r}
  integrator: {{name: rosenbrock_w, params: {json.dumps(_fixed(params))}}}
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
    bound_out = np.zeros(2)                 # the bound solve (integrators' work arrays): the same arithmetic
    lin.bind_solve(r, bound_out)()
    np.testing.assert_array_equal(bound_out, out)


class LevelParams(Params):
    times: list[float] = []
    levels: list[float] = []


class Level(Component[LevelParams]):
    """A time-driven source (no inputs, no state): levels[k] from times[k] on, 0 before."""

    type_name = "test_level"
    Params = LevelParams
    level = Output(unit="N", feedthrough=())

    def output(self, t, x, u, y):
        k = int(np.searchsorted(self.p.times, t, side="right"))
        y.level[...] = self.p.levels[k - 1] if k else 0.0


def _forced(base):
    """The declaring oscillator with a force input: ẍ = −ω² x + F."""

    class ForcedOscillator(base):
        type_name = "test_forced_oscillator"
        force = Input(unit="N")

        def derivative(self, t, x, u, dx):
            dx[0] = x[1]
            dx[1] = -self.p.omega ** 2 * x[0] + u.force[()]

    return ForcedOscillator


def _assembly_steps(tmp_path, reg, monkeypatch, params, times, levels, dt=0.01, duration=0.5):
    """Indices of the steps (t = k·dt) at which rosenbrock_w assembled J, and the run's stats."""
    for cls in (Level, _forced(reg.component("test_declared_oscillator"))):
        if cls.type_name not in reg.components:
            reg.add_component(cls)
    path = tmp_path / "forced.yaml"
    path.write_text(f"""
sim: {{duration: {duration!r}, dt: {dt!r}, integrator: {{name: rosenbrock_w, params: {json.dumps(_fixed(params))}}}}}
components:
  src: {{type: test_level, params: {{times: {times}, levels: {levels}}}}}
  osc: {{type: test_forced_oscillator, params: {{omega: 2.0, x0: 1.0, v0: 0.0}}}}
connections: [src.level -> osc.force]
record: [osc.x]
""")
    s = load_session(path, registry=reg)
    at = []                         # the run's assemblies (not the session's warm-up step: framework/warm_up.py)
    real = Linearization.assemble
    monkeypatch.setattr(Linearization, "assemble", lambda self, t: (at.append(t), real(self, t))[1])
    r = s.run()
    assert r.summary["completed"]
    return [round(t / dt) for t in at], s.integrator.stats, [round(2 * t / dt) for t in at]


def test_jacobian_refresh_on_sources_assembles_exactly_where_the_rule_says(tmp_path, reg, monkeypatch):
    """jacobian_every 4, a source jumping at 0.105 s and 0.295 s (seen at the steps starting at 0.11 and
    0.30), window 25 ms: J at steps 0, 4, 8 (every 4); 11 (the jump), 12, 13 (t < 0.135); 17, 21, 25, 29
    (every 4 from 13); 30 (the jump), 31, 32 (t < 0.325); 36, 40, 44, 48. A source that keeps its level
    (the third switch, to the same value) is no event."""
    params = {"jacobian_every": 4, "jacobian_refresh": "on_sources", "refresh_window": 0.025}
    steps, stats, _ = _assembly_steps(tmp_path, reg, monkeypatch, params, [0.105, 0.295, 0.42], [2.0, -1.0, -1.0])
    assert steps == [0, 4, 8, 11, 12, 13, 17, 21, 25, 29, 30, 31, 32, 36, 40, 44, 48]
    assert stats["source_refreshes"] == 2 and stats["jacobians"] == len(steps)
    # refresh_substeps 2: the steps at the jump and in its window are halved, J assembled at each half
    _, stats, halves = _assembly_steps(tmp_path, reg, monkeypatch, {**params, "refresh_substeps": 2},
                                       [0.105, 0.295, 0.42], [2.0, -1.0, -1.0])
    half = [0, 8, 16, 22, 23, 24, 25, 26, 27, 34, 42, 50, 58, 60, 61, 62, 63, 64, 65, 72, 80, 88, 96]
    assert halves == half
    assert stats["steps"] == 50 + 6 and stats["jacobians"] == len(half)
    # the default rule ignores the source: every 4 steps
    steps, _, _ = _assembly_steps(tmp_path, reg, monkeypatch, {"jacobian_every": 4}, [0.105, 0.3], [2.0, -1.0])
    assert steps == list(range(0, 50, 4))


class RampHoldParams(Params):
    until: float = 0.5


class RampHold(Component[RampHoldParams]):
    """A time-driven source: min(t, until) (N), continuous, constant from ``until`` on."""

    type_name = "test_ramp_hold"
    Params = RampHoldParams
    level = Output(unit="N", feedthrough=())

    def output(self, t, x, u, y):
        y.level[...] = min(t, self.p.until)


@pytest.mark.parametrize("substeps", [1, 2])
def test_refresh_on_sources_keeps_the_order(tmp_path, reg, substeps):
    """A W-method's order holds for any matrix: with J refreshed at every step while the source ramps
    (F = t) and every 3 steps once it holds (F = t0 from t0 = 0.5 s), ROS2 converges at order 2 to the
    exact solution of ẍ = −ω² x + F (ω = 2): x = cos ωt − sin ωt/ω³ + t/ω² until t0, then the free
    oscillation about t0/ω² from there. With refresh_substeps 2 the ramp's steps are halved, J at each half."""
    omega, T, t0 = 2.0, 2.0, 0.5
    for cls in (RampHold, _forced(reg.component("test_declared_oscillator"))):
        if cls.type_name not in reg.components:
            reg.add_component(cls)
    c = 1 / omega ** 2
    x0 = math.cos(omega * t0) - math.sin(omega * t0) / omega ** 3 + c * t0
    v0 = -omega * math.sin(omega * t0) - math.cos(omega * t0) / omega ** 2 + c
    errs, dts = [], (0.05, 0.025, 0.0125)
    for dt in dts:
        params = {"jacobian_every": 3, "jacobian_refresh": "on_sources", "refresh_window": 0.0,
                  "refresh_substeps": substeps}
        path = tmp_path / "ramp.yaml"
        path.write_text(f"""
sim: {{duration: {T!r}, dt: {dt!r}, integrator: {{name: rosenbrock_w, params: {json.dumps(_fixed(params))}}}}}
components:
  src: {{type: test_ramp_hold, params: {{until: {t0}}}}}
  osc: {{type: test_forced_oscillator, params: {{omega: {omega}, x0: 1.0, v0: 0.0}}}}
connections: [src.level -> osc.force]
record: [osc.x]
""")
        s = load_session(path, registry=reg)
        r = s.run()
        t, x = np.asarray(r["t"]), np.asarray(r["osc.x"])
        exact = np.where(t <= t0, np.cos(omega * t) - np.sin(omega * t) / omega ** 3 + c * t,
                         (x0 - c * t0) * np.cos(omega * (t - t0)) + v0 / omega * np.sin(omega * (t - t0)) + c * t0)
        errs.append(np.abs(x - exact).max())
        st = s.integrator.stats
        k0, n = round(t0 / dt), round(T / dt)
        assert st["source_refreshes"] == k0                         # one per step while it ramps (steps 1..k0)
        assert st["jacobians"] == 1 + substeps * k0 + len(range(k0 + 3, n, 3))  # step 0, then every 3 once it holds
        assert st["steps"] == n + (substeps - 1) * k0
    slope = np.polyfit(np.log(dts), np.log(errs), 1)[0]
    assert abs(slope - 2) < 0.3, (slope, errs)


@pytest.mark.parametrize("params, key", [({"method": "ros3"}, "method"), ({"jacobian_every": 0}, "jacobian_every"),
                                         ({"jacobian_refresh": "always"}, "jacobian_refresh"),
                                         ({"refresh_window": -1.0}, "refresh_window"),
                                         ({"refresh_substeps": 0}, "refresh_substeps"),
                                         ({"step_control": "adaptive"}, "step_control"),
                                         ({"atol_q": 0.0}, "atol_q"), ({"atol_v": -1.0}, "atol_v"),
                                         ({"rtol": -0.1}, "rtol"), ({"h_min": 0.0}, "h_min")])
def test_bad_params_name_the_key(params, key):
    with pytest.raises(ValidationError, match=key):
        RosenbrockW(params)


# -- error control (step_control: error, the default) ---------------------------------------------------------

def _controlled(tmp_path, reg, kind, tol, method="ros2", dt=0.5, T=10.0, omega=1.0, **extra):
    params = {"method": method, "step_control": "error", "atol_q": tol, "atol_v": tol, "rtol": 0.0, **extra}
    return oscillator(tmp_path, reg, kind, dt, T, omega, params)


@pytest.mark.parametrize("method", ["ros2", "ros34pw2"])
def test_error_control_tightens_the_error_with_the_tolerance(tmp_path, reg, method):
    """The embedded estimate controls the local error of the lower-order solution: ros2's (order 1) ~ C h², so
    h ~ tol^½ and the order-2 result's global error ~ h² ~ tol; ros34pw2's (order 2) ~ C h³, h ~ tol^⅓,
    global error ~ h³ ~ tol. Either way the global error falls in proportion to the tolerance (slope 1 in
    log-log, within the power-of-two ladder's quantisation of h), and every run ends on the base instants."""
    tols = (1e-3, 1e-4, 1e-5, 1e-6)
    errs, steps = [], []
    for tol in tols:
        _, r = _controlled(tmp_path, reg, "test_declared_oscillator", tol, method)
        errs.append(max_error(r, 1.0))
        steps.append(r.summary["integrator"]["steps"])
        assert np.allclose(np.diff(r["t"]), 0.5)
    slope = np.polyfit(np.log(tols), np.log(errs), 1)[0]
    assert 0.6 < slope < 1.4, (slope, errs)
    assert steps == sorted(steps) and steps[-1] > steps[0], steps


@pytest.mark.slow
def test_error_control_finds_the_explicit_limit_of_an_undeclared_stiff_term(tmp_path, reg):
    """An oscillator that declares nothing is integrated explicitly by the W-method; at ω h = 50 fixed steps
    blow up (|R| > 1), while error control shrinks the step below the explicit stability limit and keeps the
    energy (½ω²x² + ½v² = ½ω² at the start) within the tolerance's reach."""
    omega, dt, T = 100.0, 0.5, 2.0
    _, fixed = oscillator(tmp_path, reg, "test_oscillator", dt, T, omega, {"method": "ros2"})
    assert fixed.last_good_state is not None or np.abs(fixed["osc.x"]).max() > 1e3
    _, r = _controlled(tmp_path, reg, "test_oscillator", 1e-4, dt=dt, T=T, omega=omega)
    assert r.summary["completed"] and r.summary["integrator"]["rejected"] > 0
    assert r.summary["integrator"]["h_smallest"] * omega < 2.0          # below the explicit limit
    energy = 0.5 * omega ** 2 * np.asarray(r["osc.x"]) ** 2 + 0.5 * np.asarray(r["osc.v"]) ** 2
    assert np.abs(energy / (0.5 * omega ** 2) - 1.0).max() < 0.05


def test_error_control_that_cannot_meet_h_min_fails_the_run_naming_it(tmp_path, reg):
    """A step that would have to be shorter than h_min stops the run as an integrator failure that names
    h_min, the time and the tolerances, keeping the last good state."""
    _, r = _controlled(tmp_path, reg, "test_oscillator", 1e-6, dt=0.5, T=2.0, omega=1000.0, h_min=1e-3)
    assert not r.summary["completed"]
    assert "h_min = 0.001" in r.summary["stop_reason"] and "atol_q" in r.summary["stop_reason"]
    assert r.last_good_state is not None


def test_substeps_are_refused_with_error_control():
    with pytest.raises(ValidationError, match="refresh_substeps"):
        RosenbrockW({"refresh_substeps": 4})
    with pytest.raises(ValidationError, match="substeps"):
        RosenbrockW({"substeps": 2})
    RosenbrockW({"step_control": "fixed", "refresh_substeps": 4})        # fixed steps: allowed
