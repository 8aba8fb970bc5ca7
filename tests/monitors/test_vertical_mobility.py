"""The field test's evaluation (components/monitors/vertical_mobility.py) against scripted runs with known
contact, hold, distance and failure; its report in the run's summary (framework/run_reports.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.components.monitors.mobility import MobilityMonitor
from snakesim.components.monitors.vertical_mobility import VerticalMobilityEvaluation, _Window, quat_axes
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Harness
from snakesim.framework.session import load_session

ROBOT = RobotModel.load(design="eels-1.5")
RATE = 10.0


def _poses(nl, z, alpha=0.0):
    """Every link at height z, its x axis tilted alpha from world up (z) toward +x: q = Ry(alpha − 90°)."""
    phi = -math.pi / 2 + alpha
    p = np.zeros((nl, 7))
    p[:, 2] = z
    p[:, 4], p[:, 6] = math.sin(phi / 2), math.cos(phi / 2)
    return p


def _eval(**params):
    h = Harness(VerticalMobilityEvaluation, {"hold_time": 1.0, "drift_tolerance": 0.005, "contact_force": 20.0,
                                             **params}, rate=RATE, uses={"robot": ROBOT})
    return h, h.infos["link_poses"].shape[0]


# a scripted run sampled at 10 Hz: (t, height of every link, total normal force, tilt deg)
SCRIPT = ([(0.1 * k, 1.2 - 0.04 * k, 0.0, 0.0) for k in range(5)]                   # falling, no contact
          + [(0.5 + 0.1 * k, 1.0 + 0.002 * (-1) ** k, 30.0, 10.0) for k in range(11)]  # contact at 0.5, held to 1.5
          + [(1.6 + 0.1 * k, 1.03 + 0.06 * k, 30.0, 10.0) for k in range(5)]           # climbs to 1.27 at 2.0
          + [(2.1 + 0.1 * k, 1.27 - 0.074 * (k + 1), 30.0, 20.0) for k in range(5)]    # down to 0.9 at 2.5
          + [(2.6, 0.9, 30.0, 70.0)])                                                  # pitched 70°: failure


def test_scripted_run_gives_contact_hold_distance_and_failure_exactly():
    h, nl = _eval()
    for t, z, F, tilt in SCRIPT:
        h.inputs.link_poses = _poses(nl, z, math.radians(tilt))
        h.inputs.normal_force = np.array([F * 0.25] * 4)              # summed: any shape
        h.update(t)
    out = h.outputs(2.6)
    assert out["contact_made"] == 1.0 and out["t_contact"] == pytest.approx(0.5)
    # samples 0.5 .. 1.5 lie within 0.004 m <= 0.005; 1.6 (1.03) leaves the band
    assert out["max_hold_time"] == pytest.approx(1.0) and out["held"] == 1.0
    # from the height at contact, h_c = 1.002: up to 1.27, down to 0.9
    assert out["max_up"] == pytest.approx(0.268) and out["max_down"] == pytest.approx(0.102)
    assert out["climb"] == pytest.approx(-0.102)
    assert out["failed"] == 1.0 and math.degrees(float(out["max_tilt"])) == pytest.approx(70.0)
    assert "mobility failure: module_00 tilted 70.0 deg" in h.c._stop.reason
    r = h.c.report(h.u.cache, {"completed": False, "stop_reason": "evaluation: ...", "t_end_s": 2.7})
    assert r["contact"] == {"made": True, "time_s": pytest.approx(0.5), "threshold_N": 20.0}
    assert r["hold"]["from_s"] == pytest.approx(0.5) and r["hold"]["to_s"] == pytest.approx(1.5)
    assert r["hold"]["achieved"] is True
    assert r["failure"]["failed"] and r["failure"]["time_s"] == pytest.approx(2.6)
    assert "limit 60.0 deg" in r["failure"]["reason"]
    assert "tether" not in r                                            # tension unconnected
    assert any("hold: longest 1 s" in ln for ln in VerticalMobilityEvaluation.format_report(r))


def test_no_contact_means_no_hold_and_the_runs_own_stop_is_the_failure():
    h, nl = _eval(hold_time=0.5)
    for k in range(10):
        h.inputs.link_poses = _poses(nl, 1.0)                            # perfectly still, but never touching
        h.inputs.normal_force = 19.0
        h.update(0.1 * k)
    r = h.c.report(h.u.cache, {"completed": False, "stop_reason": "stop condition: slid at t = 1 s", "t_end_s": 1.0})
    assert r["contact"]["made"] is False and r["hold"]["longest_s"] == 0.0 and not r["hold"]["achieved"]
    assert r["failure"] == {"failed": True, "time_s": 1.0, "reason": "stop condition: slid at t = 1 s"}
    r = h.c.report(h.u.cache, {"completed": True})
    assert r["failure"]["failed"] is False


def test_tether_slack_fraction():
    h, nl = _eval()
    for k, T in enumerate([50.0, 0.5, 0.0, 0.0]):
        h.inputs.link_poses = _poses(nl, 1.0)
        h.inputs.normal_force = 100.0
        h.inputs.tension = np.array([T])
        h.update(0.1 * k)
    tt = h.c.report(h.u.cache, {"completed": True})["tether"]
    assert tt["max_tension_N"] == 50.0 and tt["slack_fraction"] == 0.75 and tt["slack"] is False


def test_longest_band_window_is_exact_against_brute_force():
    rng = np.random.default_rng(3)
    h = np.cumsum(rng.normal(0, 0.002, 400))
    t = 0.02 * np.arange(h.size)
    tol = 0.006
    w, best = _Window(), 0.0
    for ti, hi in zip(t, h):
        a, b = w.push(ti, hi, tol)
        best = max(best, b - a)
    brute = max(t[j] - t[i] for i in range(h.size) for j in range(i, h.size)
                if np.ptp(h[i:j + 1]) <= tol)
    assert best == pytest.approx(brute)


def test_tilt_is_the_mobility_monitors():
    m = Harness(MobilityMonitor, {}, rate=RATE, uses={"robot": ROBOT})
    nl = m.infos["link_poses"].shape[0]
    rng = np.random.default_rng(0)
    q = rng.normal(size=(nl, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    poses = np.zeros((nl, 7))
    poses[:, 3:] = q
    x, y, z, w = q.T
    R = np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
                  np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
                  np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], 1)
    np.testing.assert_allclose(quat_axes(poses, np.array([1.0, 0, 0])), R[:, :, 0], atol=1e-12)
    m.inputs.link_rotations, m.inputs.link_poses = R, poses
    e, _ = _eval(stop_on_failure=False)
    e.inputs.link_poses = poses
    e.update(0.0)
    assert float(e.outputs()["max_tilt"]) == pytest.approx(float(m.outputs()["max_tilt"]), abs=1e-12)


def test_the_monitors_60_degree_stop_is_the_evaluations_failure_in_a_run():
    """parallel-walls-climb (open-loop C on ice) ends at the mobility monitor's 60° stop; the summary's
    evaluation report carries that stop as the failure."""
    s = load_session("parallel-walls-climb", sim_overrides={"duration": 4.0})
    r = s.run()
    sm = r.summary
    assert not sm["completed"] and "mobility failure" in sm["stop_reason"] and "limit 60.0 deg" in sm["stop_reason"]
    rep = sm["reports"]["evaluation"]
    assert rep["contact"]["made"] is True
    assert rep["failure"]["failed"] and rep["failure"]["reason"] == sm["stop_reason"]
    assert "tether" in rep
