"""/sim/reset, /sim/set_pose, /sim/set_joint_positions and the /sim/reset and /sim/pause services, end to end:
an in-process run (the scene plus what ``--ros2`` adds) driven by a separate process that knows only
cyclonedds and the standard types (sim_client.py), on loopback.

A probe component snapshots the plan's whole state at every output pass, so the tests compare the state
itself: after a reset it equals X0 and XD0 bit for bit; after a placement the base pose is the one requested
(quaternion normalised) and the velocities are zero, exactly."""

from __future__ import annotations

import json
import logging
import math

import numpy as np
import pytest

from ros2_peer import peer_result, start_peer
from snakesim.framework.assembly import ComponentSpec, resolve
from state_probe import StateProbe

SCENE = """\
description: a 2-module robot falling, a bend joint driven from 0.3 rad to 0 by a discrete PID
sim: {duration: %(duration)s, dt: 0.001, integrator: rk4, record_rate: 1000}
components:
  robot: {type: multibody, params: {design: eels-1.0, modules: 2, q0: {bend_00: 0.3}}}
  hold: {type: joint_setpoints}
  pid: {type: joint_pid, rate: 100}
connections:
  - robot.joint_v -> pid.v
  - robot.joint_q -> pid.q
  - hold.setpoint -> pid.setpoint
  - pid.tau -> robot.tau
record: [robot.link_poses, robot.joint_q]
"""


@pytest.fixture(scope="module")
def registry():
    from snakesim.framework.registry import build_registry

    reg = build_registry()
    reg.add_component(StateProbe)
    return reg


def _session(tmp_path, registry, domain, duration=1.0, sim_control=None):
    from snakesim.components.ros2.attach import attach_ros2, attach_sim_control
    from snakesim.framework.session import Session

    p = tmp_path / "scene.yaml"
    p.write_text(SCENE % {"duration": duration})
    resolved = resolve(str(p), search_path=registry.assembly_paths())
    attach_ros2(resolved, registry, params={"domain_id": domain})
    if sim_control:
        attach_sim_control(resolved, sim_control)
    resolved.components["probe"] = ComponentSpec(type="test_state_probe", rate=1000.0)
    s = Session(resolved, registry)
    s.plan.caches["probe"].plan = s.plan
    return s


def _client(domain, script, seconds=30):
    return start_peer("sim_client.py", domain, seconds, json.dumps(script))


def _result(proc):
    return peer_result(proc, timeout=30, check=True)


def _robot_x(s):
    sl = next(sl for sl in s.plan.slices if sl.comp.name == "robot")
    return sl.x


@pytest.mark.slow
def test_reset_by_service_and_topic_returns_the_world_to_x0_exactly_while_time_runs_on(tmp_path, registry, dds_domain):
    domain = dds_domain()
    s = _session(tmp_path, registry, domain, duration=1.0)
    X0, XD0 = s.simulator.X0, s.simulator.XD0
    proc = _client(domain, [
        {"at": 0.25, "service": "/sim/reset", "srv": "std_srvs/srv/Empty", "request": {}},
        {"at": 0.6, "topic": "/sim/reset", "type": "Empty", "msg": {}},
    ])
    r = s.run(realtime=True)
    got = _result(proc)
    assert r.summary["completed"] and r.summary["t_end_s"] == pytest.approx(1.0)
    # the service answered, matched by the request header rmw_cyclonedds puts on it
    call = got["steps"][0]
    assert "reply" in call, call
    assert call["reply"]["header_seq"] == 1
    # exactly two ticks at which the whole state is X0, XD0 (bit for bit), one after each request; the
    # world had moved away from it before each (the robot falls, the PID integrates)
    seen = s.plan.caches["probe"].seen
    at_x0 = [k for k, (t, X, XD) in enumerate(seen) if k > 0 and np.array_equal(X, X0) and np.array_equal(XD, XD0)]
    assert len(at_x0) == 2, [seen[k][0] for k in at_x0]
    t_reset = [seen[k][0] for k in at_x0]
    assert 0.25 <= t_reset[0] < 0.6 <= t_reset[1]
    for k in at_x0:
        X, XD = seen[k - 1][1], seen[k - 1][2]
        assert not np.array_equal(X, X0) and not np.array_equal(XD, XD0)
        assert abs(X[_robot_x(s)][2] - X0[_robot_x(s)][2]) > 1e-3          # it had fallen (m)
    # the reset is the state one base step after the tick that handled the call (not before the call)
    assert call["clock_ns"] < t_reset[0] * 1e9
    # time ran forward throughout: every tick one dt after the last, /clock strictly increasing
    times = np.array([t for t, _, _ in seen])
    np.testing.assert_allclose(np.diff(times), 0.001, rtol=0, atol=1e-9)
    clock = [ns for _, ns in got["clock"]]
    assert len(clock) > 50 and all(b > a for a, b in zip(clock, clock[1:]))
    run = s.plan.caches["ros2_sim_control"]
    assert run.resets == 2 and r.summary["state_edits"] == 2 and r.summary["integrator"]["restarts"] == 2


QUAT = (0.0, 0.2, 0.0, 0.4)          # not unit: normalised on the way in
POSE = {"header": {"frame_id": "world"},
        "pose": {"position": {"x": 0.5, "y": -0.25, "z": 1.5}, "orientation": dict(zip("xyzw", QUAT))}}
MALFORMED_POSE = [
    ({**POSE, "header": {"frame_id": "map"}}, "header.frame_id = 'map' is not the world frame 'world'"),
    ({**POSE, "header": {"frame_id": ""}}, "header.frame_id = '' is not the world frame 'world'"),
    ({**POSE, "pose": {"position": {"x": math.nan}}}, "pose.position.x = nan is not finite"),
    ({**POSE, "pose": {"orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}}}, "pose.orientation has norm 0"),
    ({**POSE, "pose": {"orientation": {"z": math.inf}}}, "pose.orientation.z = inf is not finite"),
    ({**POSE, "header": {"frame_id": "world", "stamp": {"sec": 0, "nanosec": 1000}}}, "header.stamp = 1e-06 s is stale"),
]
MALFORMED_JOINTS = [
    ({"name": ["elbow_9"], "position": [0.1]}, "name[0] = 'elbow_9' is not a joint"),
    ({"name": ["bend_01"], "position": [math.nan]}, "position[0] (bend_01) = nan is not finite"),
    ({"name": ["bend_01", "twist_01"], "position": [0.1]}, "position has 1 values for 2 name"),
    ({"name": ["bend_01"], "position": [0.1], "velocity": [1.0]}, "velocity must be empty"),
    ({"name": ["bend_01", "bend_01"], "position": [0.1, 0.2]}, "name[1] = 'bend_01' appears twice"),
    ({"name": ["bend_01"], "position": [40.0]}, "position[0] (bend_01) = 40 is out of range"),
    ({"name": [], "position": []}, "name is empty"),
]


@pytest.mark.slow
def test_set_pose_and_joint_positions_land_exactly_and_bad_requests_are_rejected(tmp_path, registry, dds_domain,
                                                                                 caplog):
    domain = dds_domain()
    s = _session(tmp_path, registry, domain, duration=1.2)
    robot = s.plan.components["robot"].robot
    script = [{"at": 0.3, "topic": "/sim/set_pose", "type": "PoseStamped", "msg": POSE},
              {"at": 0.5, "topic": "/sim/set_joint_positions", "type": "JointState",
               "msg": {"name": ["bend_01", "screw_front_00"], "position": [0.25, 2.5]}}]
    script += [{"at": 0.7, "topic": "/sim/set_pose", "type": "PoseStamped", "msg": m} for m, _ in MALFORMED_POSE]
    script += [{"at": 0.7, "topic": "/sim/set_joint_positions", "type": "JointState", "msg": m}
               for m, _ in MALFORMED_JOINTS]
    proc = _client(domain, script)
    with caplog.at_level(logging.WARNING, logger="snakesim.ros2"):
        r = s.run(realtime=True)
    _result(proc)
    assert r.summary["completed"] and r.summary["t_end_s"] == pytest.approx(1.2)
    # every malformed request rejected with its reason logged, none reached the state
    text = "\n".join(rec.getMessage() for rec in caplog.records if rec.name == "snakesim.ros2")
    for _, reason in MALFORMED_POSE + MALFORMED_JOINTS:
        assert reason in text, f"no rejection '{reason}' in the log:\n{text}"
    run = s.plan.caches["ros2_sim_control"]
    assert run.rejected == len(MALFORMED_POSE) + len(MALFORMED_JOINTS)
    assert run.placements == 2 and r.summary["state_edits"] == 2
    # the pose: the root link's [x, y, z, qx, qy, qz, qw] exactly as asked (quaternion / its norm), at rest
    xs = _robot_x(s)
    nq = robot.nq
    q_unit = np.array(QUAT) / np.sqrt(np.dot(QUAT, QUAT))
    want = np.concatenate([[0.5, -0.25, 1.5], q_unit])
    seen = s.plan.caches["probe"].seen
    hits = [k for k, (t, X, _) in enumerate(seen) if np.array_equal(X[xs][:7], want)]
    assert len(hits) == 1, len(hits)
    k = hits[0]
    t_pose, X = seen[k][0], seen[k][1][xs]
    assert 0.3 <= t_pose < 0.5
    np.testing.assert_array_equal(X[nq:], 0.0)                                   # every velocity zero
    # ... and the published pose of the root link (/tf's source, recorded at that tick) is that pose
    rows = r.log["t"]
    i = int(np.flatnonzero(np.isclose(rows, t_pose, atol=1e-9))[0])
    cols = [f"robot.link_poses.{robot.tree.root}.{c}" for c in ("x", "y", "z", "qx", "qy", "qz", "qw")]
    pose = np.array([r.log[c][i] for c in cols])
    np.testing.assert_allclose(pose[:3], want[:3], rtol=0, atol=1e-12)
    assert abs(abs(pose[3:] @ q_unit) - 1) < 1e-12                               # same rotation (±q)
    # nothing after the valid placements was placed: the malformed ones (at 0.7 s) never reached the state
    assert not [t for t, X, _ in seen if t > t_pose and np.array_equal(X[xs][:7], want)]
    # the joints: the angles as given, exactly (a continuous screw joint as cos, sin), their rates zero
    hits = [k for k, (t, X, _) in enumerate(seen)
            if t > t_pose and X[xs][robot.q_names.index("bend_01")] == 0.25]
    assert hits, "bend_01 never set to 0.25 rad"
    t_j, X = seen[hits[0]][0], seen[hits[0]][1][xs]
    assert 0.5 <= t_j < 0.7
    assert X[robot.q_names.index("screw_front_00.cos")] == math.cos(2.5)
    assert X[robot.q_names.index("screw_front_00.sin")] == math.sin(2.5)
    for j in ("bend_01", "screw_front_00"):
        assert X[nq + robot.v_names.index(j)] == 0.0
    i = int(np.flatnonzero(np.isclose(rows, t_j, atol=1e-9))[0])
    assert r.log["robot.joint_q.bend_01"][i] == 0.25
    assert r.log["robot.joint_q.screw_front_00"][i] == pytest.approx(2.5, abs=1e-12)


@pytest.mark.slow
def test_pause_service_and_reset_while_paused(tmp_path, registry, dds_domain):
    """SetBool pauses (the run holds within one control period, /clock stands still), a reset while paused
    lets exactly one base step through (the one that takes the initial state) and holds again; SetBool false
    resumes."""
    domain = dds_domain()
    s = _session(tmp_path, registry, domain, duration=0.8, sim_control={"hold_timeout": 20.0})
    X0, XD0 = s.simulator.X0, s.simulator.XD0
    proc = _client(domain, [
        {"at": 0.3, "service": "/sim/pause", "srv": "std_srvs/srv/SetBool", "request": {"data": True}},
        {"at": 0.3, "sleep": 0.6},
        {"at": 0.3, "topic": "/sim/reset", "type": "Empty", "msg": {}},
        {"at": 0.3, "sleep": 0.6},
        {"at": 0.3, "service": "/sim/pause", "srv": "std_srvs/srv/SetBool", "request": {"data": False}},
    ])
    r = s.run(realtime=True)
    got = _result(proc)
    assert r.summary["completed"], r.summary["stop_reason"]
    pause, _, _, _, resume = got["steps"]
    assert pause["reply"]["success"] and pause["reply"]["message"].startswith("paused at t = ")
    assert resume["reply"]["success"] and resume["reply"]["message"] == "running"
    held_at = float(pause["reply"]["message"].split("= ")[1].split()[0])
    # held: during each 0.6 s wall sleep, /clock stood still (after its first 0.2 s)
    for k in (1, 3):
        t0 = got["steps"][k]["wall"] + 0.2
        t1 = got["steps"][k + 1]["wall"]
        during = {ns for w, ns in got["clock"] if t0 < w < t1}
        assert len(during) <= 1, sorted(during)
    # the reset while paused: the state X0 at one tick, one dt after the tick the run was held at
    seen = s.plan.caches["probe"].seen
    at_x0 = [t for k, (t, X, XD) in enumerate(seen) if k > 0 and np.array_equal(X, X0) and np.array_equal(XD, XD0)]
    assert len(at_x0) == 1
    clock = [ns for _, ns in got["clock"]]
    assert all(b >= a for a, b in zip(clock, clock[1:]))     # never back (a hold re-announces its tick)
    holds = s.plan.caches["ros2_sim_control"].holds
    assert holds == 2                                          # held at the pause, and again after the reset
    assert held_at >= 0.3 and at_x0[0] == pytest.approx(held_at + 0.001, abs=1e-9)
