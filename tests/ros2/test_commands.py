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


def _traj(names, positions=(), velocities=(), stamp=None, points=1, times=None):
    """A trajectory of ``points`` equal points (time_from_start 0, 0.1, 0.2 s, … unless ``times``), or, when
    ``positions`` is a list of lists, one point per inner list."""
    hdr = M.Header(stamp=M.time_msg(stamp) if stamp is not None else M.Time())
    rows = positions if positions and isinstance(positions[0], (list, tuple)) else [positions] * points
    vrows = velocities if velocities and isinstance(velocities[0], (list, tuple)) else [velocities] * len(rows)
    times = times if times is not None else [0.1 * k for k in range(len(rows))]
    pts = [M.JointTrajectoryPoint(positions=list(p), velocities=list(v), time_from_start=_dur(tf))
           for p, v, tf in zip(rows, vrows, times)]
    return M.JointTrajectory(header=hdr, joint_names=list(names), points=pts)


def _dur(s):
    ns = int(round(s * 1e9))
    sec, nsec = divmod(ns, 1_000_000_000)
    return M.Duration(sec=sec, nanosec=nsec)


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
    publish("/joint_commands", _traj([screw], velocities=[2.0], points=3))      # screws: speeds
    take(0.6, 2)
    out = take(0.9, 2)                                                            # past its last point
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
    ("time not increasing", "/joint_commands", lambda j: _traj([j[0]], [[0.1], [0.2], [0.3]], times=[0.0, 0.5, 0.5]),
     "points[2].time_from_start = 0.5 s is not after points[1].time_from_start = 0.5 s"),
    ("negative time", "/joint_commands", lambda j: _traj([j[0]], [[0.1]], times=[-1.0]),
     "points[0].time_from_start = -1 s is negative"),
    ("later point NaN", "/joint_commands", lambda j: _traj([j[0]], [[0.1], [math.nan]]),
     "points[1].positions[0] (%s) = nan is not finite"),
    ("repeated joint", "/joint_command", lambda j: _js([j[0], j[0]], position=[0.1, 0.2]), "name[1] = '%s' appears twice"),
    ("above the velocity limit", "/joint_command", lambda j: _js([j[0]], position=[0.1], velocity=[5.0]),
     "velocity[0] (%s) = 5 rad/s exceeds the joint's URDF velocity limit 1 rad/s"),
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


def _poly(t0, t1, ends):
    """The polynomial (numpy.polynomial, in t - t0) matching the end conditions ``ends`` = ((y0, y0', y0''...),
    (y1, y1', ...)) on [t0, t1]: solved directly, not with the component's formulas."""
    (e0, e1), T = ends, t1 - t0
    n = len(e0) + len(e1)
    rows, rhs = [], []
    for tau, conds in ((0.0, e0), (T, e1)):
        for k, v in enumerate(conds):
            P = np.polynomial.Polynomial([0.0] * k + [1.0] * 0 + [0.0] * (n - k))
            rows.append([math.prod(range(p - k + 1, p + 1)) * tau ** (p - k) if p >= k else 0.0 for p in range(n)])
            rhs.append(v)
    return np.polynomial.Polynomial(np.linalg.solve(np.array(rows), np.array(rhs)))


def test_trajectory_starts_from_the_state_cubic_to_point_0_continuous_velocity_and_holds_the_last(rig, robot):
    """JTC semantics: taken at t0 = 1.0 s (unstamped: start = t0), the set-point runs a cubic Hermite from the
    measured state (q, qd) to point 0, cubic between points, velocity continuous at every point, the last
    point held (rate 0); the joint the message does not name holds."""
    h, publish, take = rig
    j = list(robot.joints)
    bend, twist, other = j.index("bend_00"), j.index("twist_00"), j.index("bend_01")
    q, qd = np.zeros(len(j)), np.zeros(len(j))
    q[bend], qd[bend], q[twist], q[other] = -0.3, 0.8, 0.05, 0.2
    h.set_input("q", q)
    h.set_input("qd", qd)
    publish("/joint_command", _js(["bend_01"], position=[0.25]))
    take(0.99, 1)
    publish("/joint_commands", _traj(["bend_00", "twist_00"], [[0.1, 0.0], [0.5, 0.2], [-0.2, 0.2]],
                                     velocities=[[0.0, 0.0], [1.0, 0.5], [0.0, 0.0]], times=[0.1, 0.3, 0.5]))
    out = take(1.0, 2)
    assert out["applied"][0] == 2
    assert out["setpoint"][bend] == pytest.approx(-0.3, abs=1e-12) and out["rate"][bend] == pytest.approx(0.8)
    seg = [_poly(1.0, 1.1, ((-0.3, 0.8), (0.1, 0.0))), _poly(1.1, 1.3, ((0.1, 0.0), (0.5, 1.0))),
           _poly(1.3, 1.5, ((0.5, 1.0), (-0.2, 0.0)))]
    starts = [1.0, 1.1, 1.3]
    for t in np.arange(1.0, 1.5, 0.01):
        k = int(np.searchsorted(starts, t + 1e-12, side="right")) - 1
        out = h.outputs(t)
        assert out["setpoint"][bend] == pytest.approx(seg[k](t - starts[k]), abs=1e-12), t
        assert out["rate"][bend] == pytest.approx(seg[k].deriv()(t - starts[k]), abs=1e-10), t
        assert out["setpoint"][other] == 0.25                                     # not named: holds
    for T, v in ((1.1, 0.0), (1.3, 1.0)):                                        # velocity continuous at the points
        before, after = h.outputs(T - 1e-9)["rate"][bend], h.outputs(T + 1e-9)["rate"][bend]
        assert before == pytest.approx(v, abs=1e-6) and after == pytest.approx(v, abs=1e-6)
    for t in (1.5, 1.7, 3.0):                                                    # the last point holds
        out = h.outputs(t)
        assert out["setpoint"][bend] == -0.2 and out["setpoint"][twist] == 0.2 and out["rate"][bend] == 0.0
    assert h.u.cache.trajectories == []


def test_trajectory_linear_with_positions_quintic_with_accelerations(rig, robot):
    h, publish, take = rig
    j = list(robot.joints)
    bend = j.index("bend_00")
    q = np.zeros(len(j))
    q[bend] = 0.1
    h.set_input("q", q)                                  # qd not wired: the rate in force (0) is the start velocity
    publish("/joint_commands", _traj(["bend_00"], [[0.5], [0.3]], times=[0.2, 0.6]))
    take(2.0, 1)
    for t, (sp, rate) in {2.0: (0.1, 2.0), 2.1: (0.3, 2.0), 2.2: (0.5, -0.5), 2.4: (0.4, -0.5), 2.6: (0.3, 0.0)}.items():
        out = h.outputs(t)
        assert out["setpoint"][bend] == pytest.approx(sp, abs=1e-12), t
        assert out["rate"][bend] == pytest.approx(rate, abs=1e-12), t
    pts = [M.JointTrajectoryPoint(positions=[0.3], velocities=[0.0], accelerations=[0.0], time_from_start=_dur(0.1)),
           M.JointTrajectoryPoint(positions=[0.7], velocities=[0.5], accelerations=[-2.0], time_from_start=_dur(0.5))]
    publish("/joint_commands", M.JointTrajectory(joint_names=["bend_00"], points=pts))
    take(3.0, 2)
    quintic = _poly(3.1, 3.5, ((0.3, 0.0, 0.0), (0.7, 0.5, -2.0)))
    for t in np.arange(3.1, 3.5, 0.05):
        out = h.outputs(t)
        assert out["setpoint"][bend] == pytest.approx(quintic(t - 3.1), abs=1e-12), t
        assert out["rate"][bend] == pytest.approx(quintic.deriv()(t - 3.1), abs=1e-10), t


def test_stamped_trajectory_future_stamp_delays_and_a_new_one_replaces_the_old_from_now(rig, robot):
    h, publish, take = rig
    j = list(robot.joints)
    bend, twist = j.index("bend_00"), j.index("twist_00")
    publish("/joint_commands", _traj(["bend_00", "twist_00"], [[0.0, 0.0], [0.4, -0.4]], times=[0.0, 0.4],
                                     stamp=2.0))
    take(1.5, 1)                        # taken at 1.5 s; its times count from the stamp: point 0 due at 2.0 s
    out = h.outputs(1.75)               # halfway from the state at 1.5 s (set-points 0: q not wired) to point 0
    assert out["setpoint"][bend] == pytest.approx(0.0, abs=1e-12)
    out = h.outputs(2.1)
    assert out["setpoint"][bend] == pytest.approx(0.1, abs=1e-12)
    assert out["setpoint"][twist] == pytest.approx(-0.1, abs=1e-12)
    publish("/joint_commands", _traj(["bend_00"], [[-0.3]], times=[0.1]))         # replaces it at 2.2 s
    out = take(2.2, 2)
    assert out["setpoint"][bend] == pytest.approx(0.2, abs=1e-12)                 # from the state at 2.2 s
    assert out["setpoint"][twist] == pytest.approx(-0.2, abs=1e-12) and out["rate"][twist] == 0.0
    out = h.outputs(2.25)
    assert out["setpoint"][bend] == pytest.approx(-0.05, abs=1e-12)
    assert out["setpoint"][twist] == pytest.approx(-0.2, abs=1e-12)               # not named: holds
    publish("/joint_command", _js(["bend_00"], position=[0.25]))                  # a JointState takes joints over
    out = take(2.26, 3)
    assert out["setpoint"][bend] == 0.25 and h.u.cache.trajectories == []
    publish("/joint_commands", _traj(["bend_00"], [[0.1], [0.2]], times=[0.0, 0.01], stamp=2.25))
    take(2.3, 4)                                                                 # ended at 2.26 s: in the past
    assert "the whole trajectory is in the past" in h.u.cache.last_reason


def test_path_and_goal_tolerances_abort_and_count(dds_domain, robot, caplog):
    from snakesim.components.ros2.commands import Ros2Commands

    h = Harness(Ros2Commands, {"domain_id": dds_domain(), "path_tolerance": {"bend_00": 0.05},
                               "goal_tolerance": 0.01, "goal_time": 0.2}, rate=100.0, name="cmd", uses={"robot": robot})
    j = list(robot.joints)
    bend, twist = j.index("bend_00"), j.index("twist_00")
    q = np.zeros(len(j))
    h.set_input("q", q)
    h.outputs(0.0)
    run, cmd = h.u.cache, h.c
    with caplog.at_level(logging.WARNING, logger="snakesim.ros2"):
        cmd.apply(run, "/joint_commands", _traj(["bend_00", "twist_00"], [[0.5, 0.5]], times=[1.0]), 0.0, h.y)
        out = h.outputs(0.5)                     # q = 0, set-point 0.25 > 0.05 past: aborted at the next tick
        out = h.outputs(0.51)
        assert out["aborted"][0] == 1 and run.trajectories == []
        assert out["setpoint"][bend] == 0.0 and out["setpoint"][twist] == 0.0 and out["rate"][bend] == 0.0
        assert "path tolerance of bend_00 violated" in run.last_violation
        cmd.apply(run, "/joint_commands", _traj(["twist_00"], [[0.3]], times=[0.1]), 1.0, h.y)
        for t in (1.05, 1.1, 1.2):
            out = h.outputs(t)
        assert out["goal_missed"][0] == 0 and len(run.trajectories) == 1          # within goal_time: waiting
        out = h.outputs(1.31)
        assert out["goal_missed"][0] == 1 and run.trajectories == [] and out["setpoint"][twist] == 0.3
        assert "goal tolerance of twist_00 violated" in run.last_violation
        q[twist] = 0.3
        h.set_input("q", q)
        cmd.apply(run, "/joint_commands", _traj(["twist_00"], [[0.3]], times=[0.1]), 2.0, h.y)
        h.outputs(2.1)
        assert h.outputs(2.11)["goal_missed"][0] == 1 and run.trajectories == []  # reached: no violation
    lines = [r.getMessage() for r in caplog.records if r.name == "snakesim.ros2"]
    assert any("path tolerance" in x for x in lines) and any("goal tolerance" in x for x in lines)
    run.close()


def test_malformed_cdr_dropped_logged_and_counted(rig, robot, caplog):
    """A sample whose bytes do not decode as the topic's type (a joint name that is not UTF-8, as a broken writer
    sends: raw bytes under the right type; Cyclone itself refuses structurally broken CDR) is dropped by the transport with a warning naming the topic and the
    reason, counted with the rejections; the valid samples after it are applied."""
    from cyclonedds._clayer import ddspy_write

    from snakesim.components.ros2.transport import Ros2Participant

    h, publish, take = rig
    dds = Ros2Participant(h.c.p.domain_id)
    w = dds.writer("/joint_command", M.JointState)
    deadline = time.monotonic() + 10
    while not w.get_matched_subscriptions():
        assert time.monotonic() < deadline
        time.sleep(0.02)
    raw = _js(["bend_00"], position=[0.2]).serialize()
    with caplog.at_level(logging.WARNING, logger="snakesim.ros2"):
        assert ddspy_write(w._ref, raw.replace(b"bend_00", b"\xff\xfend_00")) == 0      # not UTF-8
        out = take(1.0, 1)
        publish("/joint_command", _js(["bend_00"], position=[0.2]))
        out = take(1.0, 2)
    assert out["rejected"][0] == 1 and out["applied"][0] == 1
    assert out["setpoint"][list(robot.joints).index("bend_00")] == 0.2
    assert "/joint_command: dropped a malformed sample" in h.u.cache.last_reason
    lines = [r.getMessage() for r in caplog.records if "dropped a malformed sample" in r.getMessage()]
    assert len(lines) == 1 and "/joint_command" in lines[0] and "do not decode as JointState" in lines[0]
    dds.close()


def test_the_same_reason_is_logged_at_most_once_per_period_with_a_count(rig, robot, caplog):
    from snakesim.components.ros2.rejections import RejectionLog

    h, publish, take = rig
    h.u.cache.log = RejectionLog("cmd", every=0.5)
    j = [n for n, k in zip(robot.joints, robot.joint_kinds) if k != "screw"]
    with caplog.at_level(logging.WARNING, logger="snakesim.ros2"):
        for k in range(5):
            publish("/joint_command", _js([j[0]], position=[math.nan]))
        take(1.0, 5)
        time.sleep(0.6)
        publish("/joint_command", _js([j[0]], position=[math.nan]))
        publish("/joint_command", _js(["elbow_9"], position=[0.1]))                # another reason
        out = take(1.0, 7)
    assert out["rejected"][0] == 7 and out["applied"][0] == 0
    lines = [r.getMessage() for r in caplog.records if r.name == "snakesim.ros2"]
    assert len(lines) == 3, lines
    assert "is not finite" in lines[0] and "more" not in lines[0]
    assert "is not finite" in lines[1] and "(and 4 more for this reason since the last line)" in lines[1]
    assert "'elbow_9' is not a joint" in lines[2]
