"""Integrators against the linear oscillator ẍ = −ω²x, whose solution is known
exactly: orders of convergence, energy behaviour, stiffness, blow-up reporting.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from snakesim.framework.session import load_session

ORDERS = {"semi_implicit_euler": 1, "rk4": 4, "rosenbrock2": 2}


def oscillator(scene, integrator, dt, duration, omega=1.0, params=None):
    s = scene(f"""
        sim:
          duration: {duration!r}
          dt: {dt!r}
          integrator: {{name: {integrator}, params: {json.dumps(params or {})}}}
        components:
          osc: {{type: test_oscillator, params: {{omega: {omega!r}, x0: 1.0, v0: 0.0}}}}
        record: [osc.x, osc.v, osc.energy]
        """)
    r = s.run()
    assert r.summary["completed"], r.summary["stop_reason"]
    return s, r


def max_error(r, omega):
    t = r["t"]
    return float(np.max(np.hypot(r["osc.x"] - np.cos(omega * t), (r["osc.v"] + omega * np.sin(omega * t)) / omega)))


@pytest.mark.parametrize("name, dts", [
    ("semi_implicit_euler", (0.02, 0.01, 0.005, 0.0025)),
    ("rk4", (0.2, 0.1, 0.05, 0.025)),
    ("rosenbrock2", (0.1, 0.05, 0.025, 0.0125)),
])
def test_order_of_convergence(scene, registry, name, dts):
    omega, T = 1.0, 10.0
    errors = [max_error(oscillator(scene, name, dt, T, omega)[1], omega) for dt in dts]
    slope = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    assert registry.integrator(name).order == ORDERS[name]
    assert abs(slope - ORDERS[name]) < 0.3, (slope, errors)


def test_substeps_are_smaller_steps(scene):
    """rk4 with 2 substeps at dt equals rk4 at dt/2 (sampled every other step)."""
    _, a = oscillator(scene, "rk4", 0.1, 2.0, params={"substeps": 2})
    _, b = oscillator(scene, "rk4", 0.05, 2.0)
    np.testing.assert_allclose(a["osc.x"], b["osc.x"][::2], rtol=0, atol=1e-14)


def test_dopri5_error_follows_rtol_and_meets_it(scene):
    omega, T, dt, atol = 1.0, 20.0, 1.0, 1e-14
    rtols = (1e-4, 1e-6, 1e-8)
    errors = []
    for rtol in rtols:
        s, r = oscillator(scene, "dopri5", dt, T, omega, {"rtol": rtol, "atol": atol})
        err = max_error(r, omega)
        errors.append(err)
        # Every accepted step has RMS(err_i / scale_i) <= 1 over the two states, so
        # |err_i| <= √2·(atol + rtol·1) (|x|, |v|/ω <= 1) and the local error vector is
        # at most 2·(atol + rtol) in the (x, v/ω) norm, which the ω = 1 flow preserves:
        # the global error is at most the sum of the local ones (taking the embedded
        # estimate as a bound on the error of the 5th-order solution that is kept).
        steps = s.integrator.stats["steps"]
        assert err <= steps * 2 * (atol + rtol), (rtol, err, steps)
    slope = np.polyfit(np.log(rtols), np.log(errors), 1)[0]
    assert 0.7 < slope < 1.3, (slope, errors)


def test_semi_implicit_euler_energy_stays_bounded(scene):
    """Symplectic Euler exactly conserves H̃ = E − (hω²/2)·x·v on the linear oscillator,
    so E cannot drift: with x·v <= E/ω, E0/(1 + hω/2) <= E <= E0/(1 − hω/2) forever."""
    omega, dt, periods = 2 * math.pi, 0.01, 200
    s, r = oscillator(scene, "semi_implicit_euler", dt, float(periods), omega)
    x, v, E = r["osc.x"], r["osc.v"], r["osc.energy"]
    E0 = E[0]
    assert E0 == pytest.approx(0.5 * omega ** 2)
    shadow = E - 0.5 * dt * omega ** 2 * x * v
    assert np.abs(shadow - E0).max() < 1e-11 * E0
    hw = dt * omega
    assert E.max() <= E0 / (1 - hw / 2) * (1 + 1e-12)
    assert E.min() >= E0 / (1 + hw / 2) * (1 - 1e-12)
    # the oscillation of E fills the band in the first and in the last ten periods alike
    per = int(round(1 / dt))
    first, last = E[: 10 * per], E[-10 * per:]
    assert np.ptp(last) == pytest.approx(np.ptp(first), rel=1e-3)


def _rk4_R(z):
    return 1 + z + z ** 2 / 2 + z ** 3 / 6 + z ** 4 / 24


def _ros2_R(z):
    g = 1 + 1 / math.sqrt(2)
    w = 1 / (1 - g * z)
    return 1 + 1.5 * z * w + 0.5 * z * w * (1 + z * w - 2 * w)


@pytest.mark.parametrize("name, R, tol", [("rk4", _rk4_R, 1e-10), ("rosenbrock2", _ros2_R, 1e-7)])
def test_energy_of_linear_oscillator_follows_the_stability_function(scene, name, R, tol):
    """On ẋ = A x with A skew in (ωx, v), one step multiplies the state by R(hA), so
    the energy after n steps is exactly E0·|R(iωh)|^(2n): a slow, predictable decay."""
    omega, dt, T = 2 * math.pi, 0.05, 200.0
    _, r = oscillator(scene, name, dt, T, omega)
    E = r["osc.energy"]
    n = np.arange(E.size)
    amp = abs(R(1j * omega * dt))
    assert amp < 1.0
    expected = E[0] * amp ** (2 * n)
    np.testing.assert_allclose(E, expected, rtol=tol)
    assert 1 - E[-1] / E[0] > 0.01         # the decay is real and resolved


def _chain2(registry, integrator, out_dir=None):
    rec = "[mass0.x, mass0.v, cell1/mass.x, cell1/mass.v]"
    s = load_session("mass-spring-chain", registry=registry, overrides=["n=2", "k=1e6", f"record={rec}"],
                     sim_overrides={"duration": 1.0, "dt": 0.01, "integrator": integrator})
    return s, s.run(out_dir=out_dir)


def test_rosenbrock2_is_stable_on_a_stiff_spring(registry):
    s, r = _chain2(registry, "rosenbrock2")
    k = s.plan.components["cell1/spring"].p.k
    omega = math.sqrt(2 * k)                       # relative mode of two unit masses
    assert s.resolved.sim.dt > 5 * 2 / omega       # far above 2/ω (rk4 itself is stable up to 2.83/ω)
    assert r.summary["completed"]
    x0, v0, x1, v1 = (r[c] for c in ("mass0.x", "mass0.v", "cell1/mass.x", "cell1/mass.v"))
    E = 0.5 * (v0 ** 2 + v1 ** 2) + 0.5 * k * (x1 - x0 - 1.0) ** 2
    assert E[0] == pytest.approx(0.5 * k * 0.1 ** 2)
    # L-stable: |R(iy)| < 1, so the energy never grows
    assert np.all(np.diff(E) <= 1e-9 * E[0])
    assert np.abs(v0 + v1).max() < 1e-9 * np.abs(v0).max()


@pytest.mark.filterwarnings("ignore:overflow:RuntimeWarning", "ignore:invalid value:RuntimeWarning")
def test_rk4_blow_up_is_a_named_stop_with_last_good_state(registry, tmp_path):
    s, r = _chain2(registry, "rk4", out_dir=tmp_path)
    sm = r.summary
    assert not sm["completed"]
    assert sm["stop_reason"].startswith("non-finite state in component '")
    assert sm["stop_reason"].split("'")[1] in ("mass0", "cell1/mass")
    assert sm["t_end_s"] < s.resolved.sim.duration
    good = r.last_good_state
    assert good is not None and np.isfinite(good["X"]).all()
    assert good["t"] == pytest.approx(sm["last_good_time_s"])
    assert good["t"] == pytest.approx(r["t"][-1])
    # the last good state is the state of the last recorded row
    last = {c: r[c][-1] for c in ("mass0.x", "mass0.v", "cell1/mass.x", "cell1/mass.v")}
    np.testing.assert_array_equal(good["components"]["mass0"], [last["mass0.x"], last["mass0.v"]])
    np.testing.assert_array_equal(good["components"]["cell1/mass"], [last["cell1/mass.x"], last["cell1/mass.v"]])
    saved = np.load(tmp_path / "last_good_state.npz")
    np.testing.assert_array_equal(saved["X"], good["X"])
    assert float(saved["t"]) == good["t"]
    np.testing.assert_array_equal(saved["x_cell1__mass"], good["components"]["cell1/mass"])
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["last_good_state_file"] == "last_good_state.npz"
    assert summary["stop_reason"] == sm["stop_reason"]


@pytest.mark.parametrize("name", ["semi_implicit_euler", "rk4", "dopri5", "rosenbrock2"])
def test_manifold_state_is_integrated_with_the_components_map(scene, name):
    """A heading stored as (cos θ, sin θ) with tangent θ̇ = const: every scheme's
    increment sums to h·θ̇ (weights sum to 1, the Jacobian is zero), so θ(t) is exact
    and the state stays on the unit circle."""
    s = scene(f"""
        sim: {{duration: 2.0, dt: 0.01, integrator: {name}}}
        components:
          rotor: {{type: test_rotor, params: {{rate: 1.3, angle0: 0.2}}}}
          osc: {{type: test_oscillator}}
        record: [rotor.angle, rotor.norm, osc.x]
        """)
    plan = s.plan
    # Euclidean states first, so the integrators add them in one slice
    assert [sl.comp.name for sl in plan.slices] == ["osc", "rotor"]
    assert (plan.nx, plan.ndx, plan.n_euclid_x) == (4, 3, 2)
    r = s.run()
    t = r["t"]
    wrapped = np.angle(np.exp(1j * (0.2 + 1.3 * t)))
    np.testing.assert_allclose(r["rotor.angle"], wrapped, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r["rotor.norm"], 1.0, rtol=0, atol=1e-13)
    # the Euclidean neighbour still follows cos t (to the scheme's accuracy at h = 0.01)
    assert np.abs(r["osc.x"] - np.cos(t)).max() < 0.01


def test_dopri5_giving_up_is_a_stop_with_last_good_state(scene, tmp_path):
    """With h_min far above the stable step of a stiff oscillator (ω = 1e4 rad/s:
    dopri5 needs h < ~3.3/ω = 3.3e-4 s), the error control cannot be met: the run
    stops with the integrator named and the last good state kept, like a blow-up."""
    s = scene("""
        sim:
          duration: 0.1
          dt: 0.01
          integrator: {name: dopri5, params: {h_min: 0.005, rtol: 1e-9, atol: 1e-12}}
        components:
          osc: {type: test_oscillator, params: {omega: 1.0e4, x0: 1.0, v0: 0.0}}
        record: [osc.x]
        """)
    r = s.run(out_dir=tmp_path)
    assert not r.summary["completed"]
    assert r.summary["stop_reason"].startswith("integrator dopri5 failed after t = ")
    assert "h_min" in r.summary["stop_reason"]
    assert r.last_good_state is not None and (tmp_path / "last_good_state.npz").is_file()
    np.testing.assert_array_equal(r.last_good_state["X"], [1.0, 0.0])  # failed on the first step
