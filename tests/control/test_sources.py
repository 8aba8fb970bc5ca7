"""Set-point sources: CSV trajectory (interpolation and every bad-file error), constant gaits,
the serpenoid wave, the schedule and the joint spring-damper."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.components.control import (CsvTrajectory, JointSetpoints, JointSpringDamper, Schedule,
                                         SerpenoidGait)
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Harness

ROBOT = RobotModel.load(design="eels-1.5")
NAMES = list(ROBOT.joints)
USES = {"robot": ROBOT}


def _csv(tmp_path, text, name="traj.csv"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def _traj(tmp_path, text, **kw):
    return Harness(CsvTrajectory, {"file": _csv(tmp_path, text), **kw}, uses=USES)


TEXT = "time,screw_front_01,bend_02\n0.0,1.0,0.0\n1.0,3.0,-0.5\n3.0,-1.0,0.5\n"


def test_linear_trajectory_is_exact_at_knots_and_linear_between(tmp_path):
    h = _traj(tmp_path, TEXT, default={"bend_*": 0.25})
    i, j = NAMES.index("screw_front_01"), NAMES.index("bend_02")
    for t, a, b in [(0.0, 1.0, 0.0), (1.0, 3.0, -0.5), (3.0, -1.0, 0.5)]:
        y = h.outputs(t)["setpoint"]
        assert (y[i], y[j]) == (a, b)                           # bit-exact at the knots
    for t in (0.25, 0.5, 1.7, 2.9):
        y, r = h.outputs(t)["setpoint"], h.outputs(t)["rate"]
        k = 0 if t < 1 else 1
        t0, t1 = [0.0, 1.0, 3.0][k], [0.0, 1.0, 3.0][k + 1]
        ya, yb = [1.0, 3.0, -1.0][k], [1.0, 3.0, -1.0][k + 1]
        assert y[i] == pytest.approx(ya + (yb - ya) * (t - t0) / (t1 - t0), abs=1e-15)
        assert r[i] == pytest.approx((yb - ya) / (t1 - t0), abs=1e-15)
    y = h.outputs(0.5)["setpoint"]
    assert y[NAMES.index("bend_00")] == 0.25 and y[NAMES.index("screw_front_00")] == 0.0   # defaults
    assert h.outputs(10.0)["setpoint"][i] == -1.0 and h.outputs(10.0)["rate"][i] == 0.0     # holds the end


def test_cubic_trajectory_interpolates_the_knots_and_reproduces_a_cubic(tmp_path):
    ts = np.array([0.0, 0.5, 1.2, 2.0, 3.0])
    f = lambda t: 0.3 * t ** 3 - t ** 2 + 0.5 * t - 0.2           # noqa: E731  not-a-knot reproduces cubics
    rows = "\n".join(f"{float(t)!r},{float(f(t))!r}" for t in ts)
    h = _traj(tmp_path, "time,bend_01\n" + rows + "\n", interpolation="cubic")
    i = NAMES.index("bend_01")
    for t in (0.1, 0.5, 1.7, 2.5):
        assert h.outputs(t)["setpoint"][i] == pytest.approx(f(t), abs=1e-12)
        assert h.outputs(t)["rate"][i] == pytest.approx(0.9 * t ** 2 - 2 * t + 0.5, abs=1e-11)


@pytest.mark.parametrize("text, message", [
    ("time,elbow_03\n0,1\n", "unknown joint name(s) ['elbow_03']; valid DOF joints: bend_00"),
    ("time,bend_00\n0,1\n1,2\n1,3\n", ":4: time 1 s does not increase past 1 s"),
    ("time,bend_00\n0,1\n1,nan\n", ":3: column 'bend_00': nan (values must be finite)"),
    ("time,bend_00\n0,1\n1,abc\n", ":3: column 'bend_00': 'abc' is not a number"),
    ("t,bend_00\n0,1\n", "the first column must be 'time', got 't'"),
    ("time,bend_00\n0,1\n1\n", ":3: 1 fields, the header has 2"),
    ("time,bend_00,bend_00\n0,1,1\n", "appear more than once"),
    ("time,bend_00\n", "no data rows"),
    ("", "empty file"),
])
def test_bad_csv_errors_name_the_file_line_and_what_is_valid(tmp_path, text, message):
    with pytest.raises(ValueError) as e:
        _traj(tmp_path, text)
    assert message in str(e.value)
    assert "traj.csv" in str(e.value)


def test_missing_trajectory_file_is_named(tmp_path):
    with pytest.raises(ValueError, match="trajectory file 'nowhere.csv' not found"):
        Harness(CsvTrajectory, {"file": "nowhere.csv"}, uses=USES)


def test_example_trajectory_in_configs_loads():
    h = Harness(CsvTrajectory, {"file": "configs/trajectories/eels-1.5-screw-sweep.csv"}, uses=USES)
    assert h.outputs(1.5)["setpoint"][NAMES.index("screw_front_01")] == 0.0     # halfway from 2 to -2


def test_constant_screw_speeds_with_directions_and_locked_joints():
    h = Harness(JointSetpoints, {"screw_speed": 2.0, "screw_direction": {"screw_front_0[13]": -1.0},
                                 "hold": {"bend_02": 0.3}}, uses=USES)
    y = dict(zip(NAMES, h.outputs()["setpoint"]))
    assert [y[f"screw_front_0{i}"] for i in range(4)] == [2.0, -2.0, 2.0, -2.0]
    assert y["bend_02"] == 0.3 and y["bend_00"] == 0.0 and y["twist_01"] == 0.0
    with pytest.raises(ValueError, match="matches no name"):
        JointSetpoints("g", {"hold": {"bend_9*": 0.1}}, uses=USES)


def test_serpenoid_wave_travels_along_the_body():
    p = {"amplitude": 0.4, "frequency": 0.5, "wavelength": 4.0}
    h = Harness(SerpenoidGait, p, uses=USES)
    bends = [NAMES.index(f"bend_0{i}") for i in range(4)]
    w = 2 * math.pi * 0.5
    for t in (0.0, 0.3, 1.1):
        out = h.outputs(t)
        expect = 0.4 * np.sin(w * t - 2 * math.pi * np.arange(4) / 4.0)
        np.testing.assert_allclose(out["setpoint"][bends], expect, atol=1e-15)
        np.testing.assert_allclose(out["rate"][bends], 0.4 * w * np.cos(w * t - 2 * math.pi * np.arange(4) / 4.0),
                                   atol=1e-14)
    # joint i at time t equals joint 0 a quarter period (one joint of a 4-joint wavelength) earlier
    assert h.outputs(1.0)["setpoint"][bends[1]] == pytest.approx(h.outputs(0.5)["setpoint"][bends[0]], abs=1e-15)
    side = Harness(SerpenoidGait, {**p, "kind": "sidewinding", "second_amplitude": 0.2}, uses=USES)
    tw = NAMES.index("twist_00")
    assert side.outputs(0.0)["setpoint"][tw] == pytest.approx(0.2)       # sin(π/2)


def test_schedule_switches_at_the_given_times():
    h = Harness(Schedule, {"times": [1.0, 2.5], "values": [0.0, 1.0], "initial": 1.0})
    assert [h.outputs(t)["y"][0] for t in (0.0, 0.999, 1.0, 2.0, 2.5, 9.0)] == [1, 1, 0, 0, 1, 1]
    with pytest.raises(ValueError, match="times must increase strictly"):
        Schedule("s", {"times": [1.0, 1.0], "values": [0.0, 1.0]})
    with pytest.raises(ValueError, match="times has 2 entries but values has 1"):
        Schedule("s", {"times": [1.0, 2.0], "values": [0.0]})


def test_spring_damper_torque():
    h = Harness(JointSpringDamper, {"stiffness": {"bend_*": 10.0, "screw_front_00": 1.0},
                                    "damping": {"*": 0.5}, "rest": {"bend_01": 0.2}}, uses=USES)
    q = np.zeros(len(NAMES))
    q[NAMES.index("bend_01")] = 0.5
    q[NAMES.index("screw_front_00")] = 3.0                   # continuous: rest 0, wrapped difference
    v = np.linspace(-1, 1, len(NAMES))
    h.inputs.q, h.inputs.v = q, v
    tau = h.outputs()["tau"]
    assert tau[NAMES.index("bend_01")] == pytest.approx(-10 * 0.3 - 0.5 * v[NAMES.index("bend_01")])
    assert tau[NAMES.index("twist_02")] == pytest.approx(-0.5 * v[NAMES.index("twist_02")])
    h.inputs.q = np.where(np.arange(len(NAMES)) == NAMES.index("screw_front_00"), 3.0 + 2 * math.pi, q)
    assert h.outputs()["tau"][NAMES.index("screw_front_00")] == pytest.approx(tau[NAMES.index("screw_front_00")])
