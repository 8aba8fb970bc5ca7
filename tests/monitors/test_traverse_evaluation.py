"""The traverse evaluation (components/monitors/traverse.py) against scripted paths with known distance,
speed and lateral excursion, and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.monitors.traverse import TraverseEvaluation
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Harness

ROBOT = RobotModel.load(design="eels-1.5")
RATE = 10.0


def _eval(**params):
    h = Harness(TraverseEvaluation, params, rate=RATE, uses={"robot": ROBOT})
    return h, h.infos["link_poses"].shape[0]


def _at(nl, p):
    poses = np.zeros((nl, 7))
    poses[:, :3], poses[:, 6] = p, 1.0
    return poses


def test_scripted_path_gives_distance_speed_and_lateral_exactly():
    # direction (3, 4, 0)/5; before start = 1 s the robot wanders (ignored); from t0 = 1 s it moves along û at
    # 0.2 m/s, with a lateral bump of 0.05 m at t = 2 s, then at 0.5 m/s for the last 2 s
    h, nl = _eval(direction=(3.0, 4.0, 0.0), start=1.0, steady_window=2.0, reference_speed=0.4)
    u, n = np.array([0.6, 0.8, 0.0]), np.array([-0.8, 0.6, 0.0])
    p0 = np.array([1.0, 2.0, 0.5])
    for k in range(10):
        h.inputs.link_poses = _at(nl, p0 + np.array([0.3, -0.1, 0.0]) * k)
        h.update(0.1 * k)
    for k in range(51):
        t = 1.0 + 0.1 * k
        s = 0.2 * (t - 1.0) if t <= 3.0 + 1e-9 else 0.4 + 0.5 * (t - 3.0)
        h.inputs.link_poses = _at(nl, p0 + s * u + (0.05 * n if abs(t - 2.0) < 1e-9 else 0.0))
        h.update(t)
    out = h.outputs(6.0)
    assert out["distance"] == pytest.approx(0.4 + 0.5 * 3.0)
    assert out["lateral"] == pytest.approx(0.05)
    r = h.c.report(h.u.cache, {"completed": True})
    assert r["start_s"] == pytest.approx(1.0) and r["elapsed_s"] == pytest.approx(5.0)
    assert r["mean_speed_m_s"] == pytest.approx(1.9 / 5.0)
    assert r["steady_speed_m_s"] == pytest.approx(0.5)            # the fit over the last 2 s: 4.0 .. 6.0
    assert r["efficiency"] == pytest.approx(0.5 / 0.4)
    assert r["direction"] == pytest.approx([0.6, 0.8, 0.0])
    # made good: 1.9 m along û (the bump is back on the line by the end); the path: 1.9 m plus the bump's out
    # and back, each leg the hypotenuse of 0.02 m along û (0.1 s at 0.2 m/s) and 0.05 m across
    assert r["made_good_m"] == pytest.approx(1.9)
    assert r["path_length_m"] == pytest.approx(1.9 - 0.04 + 2 * np.hypot(0.02, 0.05))
    lines = TraverseEvaluation.format_report(r)
    assert "+1.9 m along the path" in lines[0] and "125 % of the reference" in lines[0]
    assert "made good 1.9 m over a 1.97 m path" in lines[1], lines[1]


def test_a_run_that_never_reaches_start_reports_so():
    h, nl = _eval(start=5.0)
    h.inputs.link_poses = _at(nl, np.zeros(3))
    h.update(0.0)
    assert h.c.report(h.u.cache, {"completed": True}) == {"started": False, "start_s": 5.0}
    assert "never started" in TraverseEvaluation.format_report({"started": False, "start_s": 5.0})[0]


@pytest.mark.parametrize("params, words", [
    ({"direction": (0.0, 0.0, 0.0)}, ["direction", "non-zero"]),
    ({"reference_link": "wing"}, ["reference_link 'wing'", "links:"]),
])
def test_bad_parameters_name_the_key(params, words):
    with pytest.raises(ValueError) as e:
        _eval(**params)
    assert all(w in str(e.value) for w in words), str(e.value)


def test_needs_a_rate():
    with pytest.raises(ValueError, match="rate"):
        Harness(TraverseEvaluation, {}, uses={"robot": ROBOT})
