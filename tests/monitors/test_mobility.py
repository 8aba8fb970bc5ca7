"""Mobility monitor: tilt from the vertical (failure and stop), hold time, climb and contact metrics."""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

from snakesim.components.monitors import MobilityMonitor
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Harness
from snakesim.framework.registry import build_registry
from snakesim.framework.session import load_session


def _pitch(alpha):
    """Link axes whose x axis is tilted alpha from world up (z), toward +x."""
    phi = -math.pi / 2 + alpha
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _monitor(rate=10.0, **params):
    h = Harness(MobilityMonitor, params, rate=rate, uses={"robot": RobotModel.load(design="eels-1.5")})
    nl = h.infos["link_poses"].shape[0]
    return h, nl


def _feed(h, nl, alpha=0.0, z=0.0, speed=0.0, contacts=np.nan):
    h.inputs.link_rotations = np.broadcast_to(_pitch(alpha), (nl, 3, 3))
    poses = np.zeros((nl, 7))
    poses[:, 2], poses[:, 6] = z, 1.0
    h.inputs.link_poses = poses
    vel = np.zeros((nl, 6))
    vel[:, 0] = speed
    h.inputs.link_velocities = vel
    h.inputs.contacts = contacts


@pytest.mark.parametrize("vertical, alpha, fails", [
    ("line", 50.0, False), ("line", 70.0, True), ("line", 170.0, False),   # head down is vertical too
    ("up", 170.0, True), ("down", 170.0, False), ("down", 10.0, True),
])
def test_tilt_from_the_vertical_flags_and_stops(vertical, alpha, fails):
    h, nl = _monitor(vertical=vertical)
    _feed(h, nl, alpha=math.radians(alpha))
    out = h.outputs()
    expect = {"line": min(alpha, 180 - alpha), "up": alpha, "down": 180 - alpha}[vertical]
    assert math.degrees(float(out["max_tilt"])) == pytest.approx(expect)
    assert out["failed"] == float(fails)
    assert (h.c._stop.reason is not None) == fails
    if fails:
        assert "mobility failure: module_00 tilted" in h.c._stop.reason and "limit 60.0 deg" in h.c._stop.reason


def test_hold_time_climb_and_contact_metrics():
    h, nl = _monitor(hold_speed=0.01)
    _feed(h, nl, z=1.0, speed=0.005)
    for k in range(5):                              # still for 5 samples of 0.1 s
        h.update(0.1 * k)
    _feed(h, nl, z=1.3, speed=0.05, contacts=2.0)    # moved up 0.3 m, fast, touching
    out = h.outputs(0.5)
    assert out["hold_time"] == pytest.approx(0.5) and out["climb"] == pytest.approx(0.3)
    h.update(0.5)
    _feed(h, nl, z=1.1, speed=0.0, contacts=0.0)
    h.update(0.6)
    out = h.outputs(0.7)
    assert out["hold_time"] == pytest.approx(0.1) and out["max_hold_time"] == pytest.approx(0.5)
    assert out["climb"] == pytest.approx(0.1) and out["max_climb"] == pytest.approx(0.3)
    assert out["contact_made"] == 1.0 and out["t_contact"] == 0.5


def test_run_stops_on_a_mobility_failure(tmp_path):
    urdf = ('<robot name="bob"><link name="bob"><inertial><origin xyz="0 0 0"/><mass value="1"/>'
            '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>')
    (tmp_path / "bob.urdf").write_text(urdf)
    u = tmp_path / "bob.urdf"
    # x axis 30° from up, spinning about y at 2 rad/s in zero gravity: crosses 60° at t = 30°/(2 rad/s)
    q = [0.0, math.sin(-math.radians(60) / 2), 0.0, math.cos(-math.radians(60) / 2)]
    (tmp_path / "s.yaml").write_text(textwrap.dedent(f"""
        sim: {{duration: 2.0, dt: 0.001}}
        components:
          robot: {{type: multibody, params: {{urdf: "{u}", gravity: [0, 0, 0], base_quaternion: {q},
                                               base_velocity: [0, 0, 0, 0, 2.0, 0]}}}}
          mon: {{type: mobility_monitor, params: {{tilt_links: [bob]}}, rate: 100}}
        connections:
          - robot.link_rotations -> mon.link_rotations
          - robot.link_poses -> mon.link_poses
          - robot.link_velocities -> mon.link_velocities
        record: [mon.max_tilt]
    """))
    res = load_session(tmp_path / "s.yaml", registry=build_registry(load_entry_points=False)).run()
    assert "mon: mobility failure: bob tilted" in res.summary["stop_reason"]
    t_cross = math.radians(30) / 2.0
    assert t_cross < res.summary["t_end_s"] <= t_cross + 0.01 + 1e-9    # caught at the next 100 Hz sample
