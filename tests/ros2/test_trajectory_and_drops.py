"""End to end through a separate ROS 2 process beside `snakesim run --ros2` on the default scene:
a JointTrajectory is followed (ros2_control's semantics: from the state at receipt to point 0, then held),
and ordinary commands (gravity off then on, a placement 0.6 m up: a drop) do not end the run: the robot
ends resting on the ice, exit code 0."""

import csv
import json

import numpy as np
import pytest

from ros2_peer import run_beside

SCREW_RADIUS = 0.09            # m, eels-1.0
TAIL_ORIENTATION = {"x": 0.6579676578340262, "y": -0.25899529193482596, "z": -0.25899529193482596,
                    "w": 0.6579676578340264}    # the default scene's tail at rest (its x along the body)


def _signals(path):
    rows = list(csv.reader(open(path)))
    return rows[0], np.array(rows[1:], dtype=float)


@pytest.mark.slow
def test_gravity_off_on_and_a_drop_from_0_6_m_keep_the_run_and_the_robot_rests_on_the_ice(dds_domain, tmp_path):
    domain = dds_domain()
    script = [{"at": 0.4, "topic": "/enable_gravity", "type": "Bool", "msg": {"data": False}},
              {"at": 0.9, "topic": "/enable_gravity", "type": "Bool", "msg": {"data": True}},
              {"at": 1.6, "topic": "/sim/set_pose", "type": "PoseStamped",
               "msg": {"header": {"frame_id": "world"},
                       "pose": {"position": {"z": 0.6}, "orientation": TAIL_ORIENTATION}}}]
    out = tmp_path / "run"
    got, run = run_beside(("sim_client.py", domain, 60, json.dumps(script)),
                          ["--ros2", "--ros2-domain", domain, "--duration", 3.5, "--realtime", "--out", out,
                           "--quiet"], timeout=90, peer_timeout=30)
    assert run.returncode == 0
    assert all("error" not in s for s in got["steps"]), got["steps"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["outcome"] == "success" and summary["completed"] and summary["state_edits"] == 1
    h, d = _signals(out / "signals.csv")
    t = d[:, 0]
    screws = [i for i, c in enumerate(h) if c.startswith("robot.link_poses.screw_") and c.endswith(".z")]
    force = [i for i, c in enumerate(h) if c.startswith("contact.screw_normal_force")]
    weight = np.median(d[(t > 0.2) & (t < 0.35)][:, force].sum(axis=1))       # resting before any command
    dropped = t > 1.6
    assert d[dropped][:, screws].max() > 0.5, "the placement did not lift the robot"        # it was dropped
    floating = d[(t > 0.45) & (t < 0.85)][:, force].sum(axis=1)
    assert floating.size and floating.min() < 0.05 * weight, "gravity did not go off"
    end = t >= t[-1] - 0.3                                   # resting: every screw on the surface, loaded
    z = d[end][:, screws]
    assert np.all(np.abs(z - SCREW_RADIUS) < 0.006), (z.min(), z.max())
    assert np.all(d[end][:, force].sum(axis=1) > 0.9 * weight)


@pytest.mark.slow
def test_a_trajectory_from_another_process_is_followed_from_the_state(dds_domain):
    domain = dds_domain()
    got, _ = run_beside(("trajectory_peer.py", domain, "bend_01", 60),
                        ["--ros2", "--ros2-commands", "--ros2-domain", domain, "--duration", 2.0, "--realtime",
                         "--quiet"], timeout=90, peer_timeout=30)
    assert got["sent_at"] is not None
    t, q = np.array(got["joint"]).T
    t0 = got["sent_at"]
    q0 = q[np.searchsorted(t, t0)]
    assert abs(q0 - 0.3) > 0.1                                  # it had somewhere to go
    mid = q[(t > t0 + 0.25) & (t < t0 + 0.35)]                 # on its way: between the start and point 0
    assert mid.size and np.all((mid - q0) * (0.3 - q0) > 0) and np.all(np.abs(mid - q0) < abs(0.3 - q0))
    held = q[t > t0 + 1.3]                                       # point 0 at +0.6 s, held from +1.0 s
    assert held.size and np.all(np.abs(held - 0.3) < 0.03), held
    jumps = np.abs(np.diff(q[t > t0]))                           # no jump: the set-point was interpolated
    assert jumps.max() < 0.05, jumps.max()
