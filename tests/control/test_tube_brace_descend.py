"""tube-brace-descend.yaml: EELS 1.5 braced across the 0.35 m vertical tube as a twisted C, holding, then
descending by rolling its screws (issue 15). Static balance from the recorded contact forces, the descent's
rolling kinematics against each screw's own rolling velocity, the evaluation table, and the untwisted C in
the same tube, which only orbits the axis.

Rolling (no slip at a contact): a screw of envelope radius r turning at ω about its axis â, touching the wall
at the envelope point in direction ê_p (the outward radial ê_r made normal to â), moves its own centre at
v = −ω r (â × ê_p). The four screws of the twisted C prescribe different vertical speeds v_z,j (their leans
differ, 5-11°), so a rigid robot cannot roll on all of them: it moves at a speed between the slowest and the
fastest screw's, the others creeping. The untwisted C's â × ê_p are horizontal: v_z,j = 0, and the robot
orbits the tube axis at Ω = ω r / R (R the wall radius the contacts roll on)."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.monitors.vertical_mobility import quat_axes
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework.session import load_session

ROBOT = RobotModel.load(design="eels-1.5")
R_SCREW = float(ROBOT.metadata["screws"][0]["radius"])          # m, the screw envelope radius
R_TUBE = 0.175                                                  # m, terrains/vertical-tube-r0.175.yaml


@pytest.fixture(scope="module")
def run():
    s = load_session("tube-brace-descend")
    r = s.run()
    mass = sum(l.mass for l in s.plan.components["robot"].robot.tree.links)
    return s, r, mass


def _screw_kinematics(s, r):
    """Per sample and screw: centre positions (n, ns, 3) and the rolling-predicted centre velocity (n, ns, 3)."""
    T = np.asarray(r["t"])
    names = [l.name for l in s.plan.components["robot"].robot.tree.links]
    rows = [i for i, n in enumerate(names) if n.startswith("screw_")]
    P = np.asarray(r["robot.link_poses"]).reshape(len(T), -1, 7)[:, rows]
    joints = list(s.plan.components["robot"].robot.joints)
    w = np.asarray(r["robot.joint_v"])[:, [joints.index(f"screw_front_{j:02d}") for j in range(len(rows))]]
    a = np.stack([quat_axes(P[k], np.array([1.0, 0.0, 0.0])) for k in range(len(T))])     # (n, ns, 3)
    er = P[:, :, :3].copy()
    er[:, :, 2] = 0.0
    er /= np.linalg.norm(er, axis=2, keepdims=True)
    ep = er - np.einsum("kij,kij->ki", er, a)[:, :, None] * a
    ep /= np.linalg.norm(ep, axis=2, keepdims=True)
    return P[:, :, :3], -w[:, :, None] * R_SCREW * np.cross(a, ep)


def test_hold_carries_the_weight_by_wall_friction(run):
    """Static hold (gravity fully on from gravity_on + 1 s until the screws turn): the tube pushes radially
    (horizontally), so the contact forces' z components are the friction along gravity: Σ f_z = m g within 2 %.
    Every screw stays on the wall and the least load settles at the regulated target."""
    s, r, mass = run
    p = s.plan.components["brace"].p
    T = np.asarray(r["t"])
    W = np.asarray(r["contact.wrenches"]).reshape(len(T), -1, 6)
    fz = W[:, :, 2].sum(axis=1)
    hold = (T >= 4.0) & (T < p.climb_start)
    assert hold.sum() > 100
    mg = mass * 9.81
    assert np.abs(fz[hold] - mg).max() / mg < 0.02
    Fn = np.asarray(r["contact.screw_normal_force"])
    assert (Fn[T >= 1.0] > p.lost_fraction * p.target).all()
    late = hold & (T >= p.climb_start - 3.0)
    assert Fn[late].min(axis=1).mean() == pytest.approx(p.target, rel=0.1)


def test_descent_speed_lies_between_the_screws_rolling_speeds(run):
    """While the screws turn at full speed, every screw's rolling velocity points down (the twist's lean) and
    the centre of mass sinks at a speed between the slowest and the fastest screw's prediction, window by
    window (the leans change as the brace reshapes, so the speed drifts)."""
    s, r, _ = run
    p = s.plan.components["brace"].p
    T = np.asarray(r["t"])
    _, V = _screw_kinematics(s, r)
    drive = (T >= p.climb_start + p.spin_up) & (T < p.climb_stop)
    assert (V[drive, :, 2] < 0).all()                                            # every screw rolls down
    z = np.asarray(r["robot.com"])[:, 2]
    t0 = p.climb_start + p.spin_up
    checked = 0
    while t0 + 1.0 <= p.climb_stop:
        w = (T >= t0) & (T < t0 + 1.0)
        vz = np.polyfit(T[w], z[w], 1)[0]
        vj = V[w, :, 2].mean(axis=0)
        assert vj.min() <= vz <= vj.max(), (t0, vz, vj)
        checked += 1
        t0 += 1.0
    assert checked >= 5


def test_evaluation_table(run):
    """Contact at once, the >= 10 s static hold before the screws turn, then a descent within the
    rolling bounds integrated over the run, no mobility failure."""
    s, r, _ = run
    p = s.plan.components["brace"].p
    rep = r.summary["reports"]["evaluation"]
    assert r.summary["completed"], r.summary["stop_reason"]
    assert rep["contact"]["made"] and rep["contact"]["time_s"] < 0.1
    assert rep["hold"]["achieved"] and rep["hold"]["longest_s"] >= 10.0
    assert rep["hold"]["to_s"] <= p.climb_start + 0.5
    T = np.asarray(r["t"])
    _, V = _screw_kinematics(s, r)
    lo = -np.trapezoid(V[:, :, 2].max(axis=1), T)                                # slowest screw, m down
    hi = -np.trapezoid(V[:, :, 2].min(axis=1), T)                                # fastest screw
    vd = rep["vertical_distance"]
    assert lo <= vd["down_m"] <= hi, (lo, vd["down_m"], hi)
    assert vd["down_m"] >= 0.5 and vd["up_m"] < 5e-3
    assert rep["failure"]["failed"] is False and rep["max_tilt_deg"] < 60.0


PLANAR_C = ["q=[-0.345902, -1e-06, 5e-06, 0.265273, -0.0, -1e-05, 0.99259, 1e-06, -5e-06, -0.036113, 2e-06, 8e-06]",
            "pose={position: [-1e-06, 0.279571, 0.073544], quaternion: [0.583061, -0.5830591, 0.4000527, 0.4000498]}",
            "torque_pattern={bend_01: 7.361, bend_02: 32.943, bend_03: 23.565}"]


def test_untwisted_brace_only_orbits_the_axis():
    """Why the brace is twisted: the walls' planar C (placement-walls.yaml, pre-loaded) fits this tube
    exactly (its contacts at y = ±0.175 m); turning its screws the same way rolls every contact horizontally,
    so it orbits the axis at Ω = ω r / R and neither rises nor sinks."""
    w = 8.0
    s = load_session("tube-brace-descend", sim_overrides={"duration": 3.0},
                     overrides=PLANAR_C + ["gravity_on=0.0", "climb_start=1.0", "spin_up=0.5", f"climb_speed={w}"])
    r = s.run()
    T = np.asarray(r["t"])
    P, V = _screw_kinematics(s, r)
    spin = T >= 1.6
    assert np.abs(V[spin, :, 2]).max() < 0.02 * w * R_SCREW                    # horizontal rolling
    theta = np.unwrap(np.arctan2(P[:, 0, 1], P[:, 0, 0]))
    rate = abs(np.polyfit(T[spin], theta[spin], 1)[0])
    assert rate == pytest.approx(w * R_SCREW / R_TUBE, rel=0.03)
    z = np.asarray(r["robot.com"])[:, 2]
    assert np.abs(z - z[0]).max() < 5e-3
