"""`snakesim run --ros2` seen from a separate process that knows only cyclonedds and the standard types."""

import json

import pytest

from ros2_peer import run_beside

RATE = 50.0           # Hz, /joint_states and /clock as set on the command line
DURATION = 1.0        # s simulated


@pytest.mark.slow
def test_joint_states_at_the_set_rate_and_clock_advancing(dds_domain):
    from snakesim.components.multibody.robot_model import RobotModel

    domain = dds_domain()
    got, _ = run_beside(("subscriber.py", domain, 40),
                        ["robot-zero-g", "--set", "robot.modules=3", "--duration", DURATION, "--ros2-domain", domain,
                         "--ros2-rate", f"joint_states={RATE:g}", "--ros2-rate", f"clock={RATE:g}", "--quiet"],
                        timeout=60, peer_timeout=30)
    robot = RobotModel.load(design="eels-1.0", modules=3)
    assert got["names"] == list(robot.joints) and len(got["position_sample"]) == robot.nj
    stamps = got["joint_states"]
    expected = int(DURATION * RATE)
    assert len(stamps) >= 0.8 * expected, f"{len(stamps)} of ~{expected} /joint_states received"
    gaps = {round(b - a, 6) for a, b in zip(stamps, stamps[1:])}
    assert gaps == {round(1 / RATE, 6)}, f"stamps not {1 / RATE} s apart: {sorted(gaps)}"
    clock = got["clock"]
    assert len(clock) >= 0.8 * expected and all(b > a for a, b in zip(clock, clock[1:]))
    assert clock[-1] >= DURATION - 2 / RATE
    assert got["tf_count"] > 0 and got["tf_frames"][0][0] == "world"
    # the URDF with its meshes as file:// URIs (components/ros2/robot_description.py)
    from snakesim.components.ros2.robot_description import ros_robot_description

    assert got["description_chars"] == len(ros_robot_description(robot))


FALLING = """\
description: a 3-module robot falling freely, joints held by position PIDs (set-points from ROS 2)
sim: {duration: %(duration)s, dt: 0.001, integrator: rk4}
components:
  robot: {type: multibody, params: {design: eels-1.0, modules: 3}}
  hold: {type: joint_setpoints}
  pid: {type: joint_pid}
connections:
  - robot.joint_v -> pid.v
  - robot.joint_q -> pid.q
  - hold.setpoint -> pid.setpoint
  - pid.tau -> robot.tau
"""
JOINT = "bend_01"


def _accel(samples, t0, t1):
    """Second-order coefficient ×2 of a quadratic fit of (t, z) in [t0, t1]: the vertical acceleration."""
    import numpy as np

    pts = np.array([(t, z) for t, z in samples if t0 <= t <= t1])
    assert len(pts) >= 8, f"only {len(pts)} /tf samples in [{t0:.2f}, {t1:.2f}] s"
    return 2 * np.polyfit(pts[:, 0] - t0, pts[:, 1], 2)[0]


@pytest.mark.slow
def test_commands_move_joints_toggle_gravity_and_malformed_are_rejected(dds_domain, tmp_path):
    """A separate commander sets a joint, sees it move in /joint_states, turns gravity off and sees the fall
    stop accelerating in /tf, sends every kind of malformed command and sees publishing go on (the joint
    keeps its set-point); the run's log names each rejection. Then it pauses the run, steps it exactly N
    base steps (/clock advances by N·dt) and resumes it."""
    domain = dds_domain()
    scene = tmp_path / "falling.yaml"
    duration = 4.0
    scene.write_text(FALLING % {"duration": duration})
    got, run = run_beside(("commander.py", domain, JOINT, 40),
                          [scene, "--realtime", "--ros2-domain", domain, "--ros2-commands", "--ros2-rate", "tf=100",
                           "--quiet", "--out", tmp_path / "out"], timeout=90, peer_timeout=30)
    assert got["matched"], "the commander's writers never matched the run's readers"
    # set-points: the joint moved to the commanded angle
    assert got["moved_at"] is not None, f"{JOINT} never reached the set-point: {got['joint'][-3:]}"
    # gravity: falling at g before, not accelerating after
    t_off = got["gravity_off_at"]
    assert t_off is not None
    before = _accel(got["heights"], t_off - 0.4, t_off - 0.02)
    after = _accel(got["heights"], t_off + 0.1, t_off + 0.4)
    print(f"moved at {got['moved_at']:.3f} s, gravity off at {t_off:.3f} s: vertical acceleration {before:.2f} "
          f"before, {after:.3f} m/s² after; {got['stamps_after_malformed']} /joint_states after the malformed")
    assert before == pytest.approx(-9.81, abs=1.0) and abs(after) < 1.0, (before, after)
    # malformed commands: rejected (logged, naming the field), the run went on, the joint held its set-point
    t_bad = got["malformed_at"]
    assert t_bad is not None and got["stamps_after_malformed"] >= 20
    assert got["last_stamp"] >= duration - 0.05
    late = [q for t, q in got["joint"] if t > t_bad + 0.2]
    assert late and all(abs(q - 0.4) < 0.05 for q in late), late[-3:]
    for reason in ("name[0] = 'no_such_joint' is not a joint", "position[0] (bend_01) = nan is not finite",
                   "points[0].positions[0] (bend_01) = inf is not finite",
                   "points[0].positions has 2 values for 1 joint_names", "header.stamp = 1e-09 s is stale"):
        assert reason in run.stderr, f"no rejection '{reason}' in the run's log:\n{run.stderr[-3000:]}"
    # pause, step exactly N base steps (dt = 1 ms), resume: /clock holds, then advances by exactly N·dt
    assert got["paused_at_ns"] is not None and got["stepped_to_ns"] is not None, got
    assert got["paused_at_ns"] > t_bad * 1e9
    assert got["stepped_to_ns"] - got["paused_at_ns"] == got["steps"] * 1_000_000, \
        (got["paused_at_ns"], got["stepped_to_ns"])
    assert got["resumed"] and got["clock_after_resume_ns"] > got["stepped_to_ns"]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["completed"] and summary["held_wall_time_s"] >= 0.5
