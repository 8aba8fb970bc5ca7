"""The ros2_commands source in a Harness, fed by a writer on a loopback domain: valid commands applied
(zero-order hold), each malformed kind rejected with its reason, counted and never applied."""

import logging
import math
import time

import numpy as np
import pytest

from snakesim.framework.harness import Harness

M = pytest.importorskip("snakesim.components.ros2.messages")


@pytest.fixture(scope="module")
def robot():
    from snakesim.components.multibody.robot_model import RobotModel

    return RobotModel.load(design="eels-1.0", modules=2)


@pytest.fixture
def rig(dds_domain, robot):
    """(harness, publish(topic, msg), take(t) -> outputs): the source and a writer per topic, matched."""
    from snakesim.components.ros2.commands import Ros2Commands
    from snakesim.components.ros2.transport import Ros2Participant

    domain = dds_domain()
    h = Harness(Ros2Commands, {"domain_id": domain, "max_age": 0.1}, rate=100.0, name="cmd", uses={"robot": robot})
    h.outputs(0.0)                                        # opens the readers
    dds = Ros2Participant(domain)
    writers = {topic: dds.writer(topic, typ) for topic, typ in h.c.topics()}
    deadline = time.monotonic() + 10
    while any(not w.get_matched_subscriptions() for w in writers.values()):
        assert time.monotonic() < deadline, "readers and writers did not match on loopback"
        time.sleep(0.02)

    def publish(topic, msg):
        writers[topic].write(msg)

    def take(t, expect_total):
        """Outputs at t once expect_total messages (applied + rejected) have been taken."""
        deadline = time.monotonic() + 5
        while True:
            out = h.outputs(t)
            if out["applied"][0] + out["rejected"][0] >= expect_total or time.monotonic() > deadline:
                return out
            time.sleep(0.01)

    yield h, publish, take
    h.u.cache.close()
    dds.close()


def _js(names, position=(), velocity=(), stamp=None):
    hdr = M.Header(stamp=M.time_msg(stamp) if stamp is not None else M.Time())
    return M.JointState(header=hdr, name=list(names), position=list(position), velocity=list(velocity))


def _traj(names, positions=(), velocities=(), stamp=None, points=1):
    hdr = M.Header(stamp=M.time_msg(stamp) if stamp is not None else M.Time())
    pts = [M.JointTrajectoryPoint(positions=list(positions), velocities=list(velocities))
           for _ in range(points)]
    return M.JointTrajectory(header=hdr, joint_names=list(names), points=pts)


def test_valid_commands_applied_and_held(rig, robot):
    h, publish, take = rig
    j = robot.joints
    bend = [n for n in j if n.startswith("bend")][0]
    screw = [n for n, k in zip(j, robot.joint_kinds) if k == "screw"][0]
    out = take(0.0, 0)
    assert np.isnan(out["gravity"][0]) and np.all(out["setpoint"] == 0) and out["applied"][0] == 0
    publish("/joint_command", _js([bend], position=[0.3], velocity=[0.1], stamp=0.5))
    out = take(0.5, 1)
    assert out["applied"][0] == 1 and out["rejected"][0] == 0
    assert out["setpoint"][j.index(bend)] == 0.3 and out["rate"][j.index(bend)] == 0.1
    publish("/joint_commands", _traj([screw], velocities=[2.0], points=3))      # screws: speeds; later points ignored
    out = take(0.6, 2)
    assert out["setpoint"][j.index(screw)] == 2.0 and out["rate"][j.index(screw)] == 0.0
    assert out["setpoint"][j.index(bend)] == 0.3                                  # held (zero-order hold)
    publish("/enable_gravity", M.Bool(data=False))
    out = take(0.7, 3)
    assert out["gravity"][0] == 0.0
    publish("/enable_gravity", M.Bool(data=True))
    assert take(0.8, 4)["gravity"][0] == 1.0
    out = take(0.9, 4)                                                            # nothing new: held
    assert out["applied"][0] == 4 and out["setpoint"][j.index(bend)] == 0.3


MALFORMED = [
    ("unknown joint", "/joint_command", lambda j: _js(["elbow_9"], position=[0.1]), "name[0] = 'elbow_9' is not a joint"),
    ("NaN", "/joint_command", lambda j: _js([j[0]], position=[math.nan]), "position[0] (%s) = nan is not finite"),
    ("infinite", "/joint_commands", lambda j: _traj([j[0]], positions=[math.inf]),
     "points[0].positions[0] (%s) = inf is not finite"),
    ("lengths", "/joint_command", lambda j: _js([j[0], j[1]], position=[0.1]), "position has 1 values for 2 name"),
    ("trajectory lengths", "/joint_commands", lambda j: _traj([j[0]], positions=[0.1, 0.2]),
     "points[0].positions has 2 values for 1 joint_names"),
    ("stale", "/joint_command", lambda j: _js([j[0]], position=[0.1], stamp=0.2), "header.stamp = 0.2 s is stale"),
    ("out of range", "/joint_command", lambda j: _js([j[0]], position=[100.0]), "position[0] (%s) = 100 is out of range"),
    ("empty trajectory", "/joint_commands", lambda j: _traj([j[0]], points=0), "points is empty"),
    ("repeated joint", "/joint_command", lambda j: _js([j[0], j[0]], position=[0.1, 0.2]), "name[1] = '%s' appears twice"),
]


@pytest.mark.parametrize("kind,topic,make,reason", MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_rejected_with_reason_never_applied(rig, robot, caplog, kind, topic, make, reason):
    h, publish, take = rig
    j = [n for n, k in zip(robot.joints, robot.joint_kinds) if k != "screw"]
    before = take(1.0, 0)
    with caplog.at_level(logging.WARNING, logger="snakesim.ros2"):
        publish(topic, make(j))
        out = take(1.0, 1)
    assert out["rejected"][0] == 1 and out["applied"][0] == 0
    np.testing.assert_array_equal(out["setpoint"], before["setpoint"])
    np.testing.assert_array_equal(out["rate"], before["rate"])
    text = reason % j[0] if "%s" in reason else reason
    assert text in h.u.cache.last_reason
    logged = [r for r in caplog.records if r.name == "snakesim.ros2"]
    assert len(logged) == 1 and topic in logged[0].getMessage() and text in logged[0].getMessage()
    # the run goes on: a valid command after it is applied
    publish("/joint_command", _js([j[0]], position=[0.2]))
    out = take(1.0, 2)
    assert out["applied"][0] == 1 and out["setpoint"][robot.joints.index(j[0])] == 0.2


def test_mode_rules(rig, robot):
    h, publish, take = rig
    screw = [n for n, k in zip(robot.joints, robot.joint_kinds) if k == "screw"][0]
    bend = [n for n in robot.joints if n.startswith("bend")][0]
    publish("/joint_command", _js([screw], position=[1.0]))
    assert "is velocity-controlled" in (take(0.0, 1), h.u.cache.last_reason)[1]
    publish("/joint_command", _js([bend], velocity=[1.0]))
    assert "is position-controlled" in (take(0.0, 2), h.u.cache.last_reason)[1]


def test_attach_rule_schedule_kept_unless_takeover(dds_domain):
    from snakesim.components.ros2.attach import attach_commands, attach_ros2
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry

    reg = default_registry()
    r = resolve("surface-screw-traverse", search_path=reg.assembly_paths(), overrides=["robot.modules=2"])
    attach_ros2(r, reg, params={"domain_id": dds_domain()})
    spec = r.components["ros2_commands"]
    assert spec.params["joints"] is False and spec.params["gravity"] is True
    assert ("phases.setpoint", "pid.setpoint") in [c[:2] for c in r.connections]
    assert ("ros2_commands.gravity", "robot.gravity") in [c[:2] for c in r.connections]
    attach_commands(r, reg, takeover=True)
    pairs = [c[:2] for c in r.connections]
    assert ("phases.setpoint", "pid.setpoint") not in pairs and ("phases.rate", "pid.rate_ref") not in pairs
    assert {("ros2_commands.setpoint", "pid.setpoint"), ("ros2_commands.rate", "pid.rate_ref"),
            ("robot.joint_q", "ros2_commands.q"), ("ros2_commands.gravity", "robot.gravity")} <= set(pairs)
    assert r.components["ros2_commands"].params["joints"] is True
    assert sum(d == "pid.setpoint" for _, d, _ in r.connections) == 1
