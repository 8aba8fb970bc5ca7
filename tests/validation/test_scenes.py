"""Every scene builds and runs, and shows the physics it is there for.

tube-dangling: a robot hanging still from one tether is in static balance, so the tether
tension equals the robot's weight m·g (m summed from the model's links). Swinging, it reaches
the tube wall (radius 0.3 m) and the wall pushes back.
parallel-walls-climb: the C set-points press screws into BOTH walls (contact forces on screws
on opposite sides of the gap); on ice the open-loop grip fails after the tether's release and
the mobility monitor ends the run, naming the failure (tilt past 60 deg).
dem-surface: it runs to the end and the terrain carries the robot.
u-channel / moulin: placed by the settling algorithm (paper 2.2.6): the settle latches (phase
output), every screw's nearest sample is within the contact band then (penetration counts), and
the run completes or stops with a stated reason; in the U the floor then carries the weight and
the screws turn at the commanded speed; in the moulin the four screws span less than half the
shaft, so no positive self-equilibrated pre-load exists (Σ F_s n̂_s = 0 needs normals on both
sides of some plane) and the latched pre-load is ~0 N.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from validation_scenes import run

G = 9.81
SCENES = ["surface-screw-traverse", "tube-dangling", "parallel-walls-climb", "u-channel", "moulin", "dem-surface"]


def _weight(s):
    return s.plan.components["robot"]._ta.mass.sum() * G


def test_dangling_tether_tension_is_the_robot_weight_at_rest():
    s, r = run("tube-dangling", ["swing=0.0"], {"duration": 3.0})
    assert r.summary["completed"], r.summary
    late = r["t"] >= 2.0
    assert r["tether.tension"][late, 0].mean() == pytest.approx(_weight(s), rel=1e-3)
    assert r["contact.contacts"][:, 0].max() == 0          # hanging on the axis: clear of the wall


def test_dangling_swing_reaches_the_tube_wall():
    s, r = run("tube-dangling", [], {"duration": 2.5})
    assert r.summary["completed"], r.summary
    assert r["contact.normal_force"][:, 0].max() > 0
    # screws stay inside the tube: contact depth bounded by the penalty force (k = 1e5 N/m)
    names = s.plan.components["robot"].robot.links
    poses = r["robot.link_poses"].reshape(len(r["t"]), len(names), 7)
    screws = [i for i, n in enumerate(names) if n.startswith("screw_")]
    radial = np.hypot(poses[:, screws, 0], poses[:, screws, 1])
    assert radial.max() < 0.3 - 0.09 + 0.02


def test_climb_presses_both_walls_then_the_monitor_stops_the_failed_run():
    s, r = run("parallel-walls-climb", [], {"duration": 4.0})
    assert not r.summary["completed"]
    reason = r.summary["stop_reason"]
    assert reason.startswith("monitor: mobility failure") and "limit 60.0 deg" in reason, reason
    assert r["monitor.failed"][-1] == 1.0 and r["monitor.max_tilt"][-1] > math.radians(60.0)
    # before the release (1.5 s) the pushed C touches both walls
    names = s.plan.components["robot"].robot.links
    t = r["t"]
    i = np.searchsorted(t, 1.4)
    lay = s.plan.components["contact"].layout
    fn = r["contact.screw_normal_force"][i]
    ys = r["robot.link_poses"][i].reshape(len(names), 7)[lay.screw_row, 1]      # screw link centres, y
    pressing = fn > 1.0
    assert (ys[pressing] > 0).any() and (ys[pressing] < 0).any(), (fn, ys)
    # and the release is followed by the failure, not preceded by it
    assert float(reason.rsplit("t = ", 1)[1].split()[0]) > 1.5


@pytest.mark.parametrize("scene, horizon", [("dem-surface", 1.5)])
def test_scene_runs_and_the_terrain_or_tether_carries_the_robot(scene, horizon):
    s, r = run(scene, [], {"duration": horizon})
    assert r.summary["completed"], r.summary
    late = r["t"] >= horizon - 0.3
    support = r["contact.normal_force"][late, 0].mean()
    # roughly in balance once settled: vertical accelerations are transient (±25 %)
    assert support == pytest.approx(_weight(s), rel=0.25)


def _settled(s, r):
    """Index of the first latched sample; checks the settle's own latch conditions just before it."""
    settle = s.plan.components["settle"]
    phase = r["settle.phase"][:, 0]
    latched = np.flatnonzero(phase >= 1.0)
    assert latched.size, f"never latched; stop reason: {r.summary['stop_reason']}"
    i = int(latched[0])
    assert np.all(phase[:i] == 0.0)
    gap = r["settle.gap"][i - 1]                                # the last settling sample
    # every screw in contact (φ ≤ band; penetration bounded by the penalty: 1 mm carries 100 N per sample)
    assert np.all(gap <= settle.p.contact_band) and np.all(gap >= -5e-3), gap
    assert r["settle.max_speed"][i - 1, 0] <= settle.p.max_speed
    assert r["settle.settle_time"][-1, 0] == pytest.approx(r["t"][i], abs=0.011)    # record period 10 ms
    assert r.summary["completed"] or r.summary["stop_reason"], r.summary
    return i


def test_u_channel_settles_onto_the_floor_then_holds_and_turns_its_screws():
    s, r = run("u-channel", [], {"duration": 1.5})
    _settled(s, r)
    assert r.summary["completed"], r.summary
    t, hold = r["t"], r["settle.hold_time"][-1, 0]
    assert hold < 1.5 - 0.5 - 0.3                              # gravity on, then the drive 0.5 s later
    # gravity on: the floor carries the weight (vertical accelerations transient, ±25 %)
    late = t >= 1.2
    assert r["contact.normal_force"][late, 0].mean() == pytest.approx(_weight(s), rel=0.25)
    # the drive hand-over: screws at screw_speed (3 rad/s) from hold + drive_delay, still before it
    names = s.plan.components["robot"].robot.joints
    screws = [k for k, n in enumerate(names) if n.startswith("screw_")]
    v = r["robot.joint_v"][:, screws]
    assert np.abs(v[t < hold + 0.45]).max() < 0.3
    assert v[late].mean() == pytest.approx(3.0, rel=0.1)


@pytest.mark.slow
def test_moulin_settles_onto_the_wall_and_the_short_helix_gets_no_squeeze():
    s, r = run("moulin", [], {"duration": 4.2})
    i = _settled(s, r)
    assert r.summary["completed"], r.summary
    assert r["settle.hold_time"][-1, 0] < 4.2              # gravity came on
    settle, F = s.plan.components["settle"], s.plan.caches["settle"].preload_forces
    # the screws' outward normals all lie within a half-plane: the pre-load cannot balance
    assert np.abs(F).max() < 0.05 * settle.p.preload, F
    assert r["t"][i] > 0.5


@pytest.mark.parametrize("scene", SCENES)
def test_scene_declares_the_robot_and_terrain_parameters(scene):
    from validation_scenes import session
    s = session(scene, ["robot.modules=3"] if scene in ("surface-screw-traverse", "tube-dangling",
                                                          "dem-surface") else [])
    assert {"robot", "terrain"} <= set(s.resolved.parameters)
    assert set(s.resolved.parameters["robot"]) == {"name", "modules", "head", "urdf"}
