"""The default scene, the crescent screw traverse (paper 4.2), on a shortened schedule.

Predictions from the geometry alone (no numbers from the code): the crescent lies with its
chord along +x and its concave side towards +y (bends positive about the vertical). A screw
pair pushes its module along the module's axis, in the direction of the spin's sign (the
steady axial speed u* has the sign of ω, contact/steady_state.py), so:
  - all screws forward: the robot moves along the chord, +x; all reversed: back, −x;
  - head half forward, tail half reversed: the head modules push along their headings
    (+x, +y), the tail modules against theirs (−x, +y): the x parts cancel, the robot moves to
    the concave side, +y; the opposite combination moves it to the convex side, −y.
  - the robot rests on the ice: the contact carries its weight.
And the fig. 14 quantities (tail x, y, yaw) of the default setting against a tight reference
(rk4, dt/4): the numerical error must be far below the model-vs-hardware error the paper
reports (4 cm, 0.06 rad over 45 s) — here at most a tenth of it over the short horizon.
"""

from __future__ import annotations

import numpy as np
import pytest

from validation_scenes import TRAVERSE, reference_track, run, tail_track, track_error

G = 9.81
SHORT = ["settle=0.5", "phase=1.5"]            # phases start at 0.5, 2.0, 3.5, 5.0, 6.5 s


@pytest.fixture(scope="module")
def traverse():
    s, r = run(TRAVERSE, SHORT + ["phase=1.5"], {"duration": 6.5})
    assert r.summary["completed"], r.summary
    return s, r


def _window(r, t0, t1):
    t = r["t"]
    return (t >= t0) & (t <= t1)


def _com_shift(r, t0, t1):
    t, com = r["t"], r["robot.com"]
    i0, i1 = np.searchsorted(t, t0), np.searchsorted(t, t1)
    return com[i1, :2] - com[i0, :2]


def test_initial_shape_is_the_crescent_with_its_chord_along_x(traverse):
    s, r = traverse
    names = s.plan.components["robot"].robot.links
    poses = r["robot.link_poses"][0].reshape(len(names), 7)
    mods = np.array([poses[names.index(n), :3] for n in names if n.startswith("module_")])
    chord = mods[-1] - mods[0]
    assert abs(chord[1]) < 0.05 * abs(chord[0]) and chord[0] > 0          # chord along +x
    mid = mods[len(mods) // 2]
    assert mid[1] < min(mods[0, 1], mods[-1, 1])                          # bulges to −y: concave side +y
    assert np.ptp(mods[:, 2]) < 1e-6                                       # lying flat


@pytest.mark.parametrize("t0, t1, axis, sign", [(0.7, 2.0, 0, +1), (2.2, 3.5, 0, -1),
                                                (3.7, 5.0, 1, +1), (5.2, 6.5, 1, -1)],
                         ids=["all-forward:+x", "all-reversed:-x", "head-fwd-tail-rev:+y", "head-rev-tail-fwd:-y"])
def test_each_screw_combination_moves_the_robot_where_the_geometry_predicts(traverse, t0, t1, axis, sign):
    _, r = traverse
    d = _com_shift(r, t0, t1)
    assert sign * d[axis] > 0.02, d                                # moves, in the predicted direction
    assert sign * d[axis] > abs(d[1 - axis]), d                    # mostly along it


def test_the_ice_carries_the_robot_weight(traverse):
    s, r = traverse
    weight = s.plan.components["robot"]._ta.mass.sum() * G
    fn = r["contact.normal_force"][_window(r, 0.3, 6.5), 0]
    # rigid-body vertical balance on flat ice: only transients from the screws' torque ripple remain
    assert fn.mean() == pytest.approx(weight, rel=2e-3)


def test_screws_track_the_schedule(traverse):
    """The velocity PIDs follow the commanded screw speeds (paper: 'tuned to very low tracking error')."""
    s, r = traverse
    w = _window(r, 1.5, 1.95)                                       # late in the all-forward phase
    sp, v = r["phases.setpoint"][w], r["robot.joint_v"][w]
    screws = np.array([n.startswith("screw_") for n in s.plan.components["robot"].robot.joints])
    err = np.abs(v[:, screws] - sp[:, screws]).max()
    assert err < 0.05 * np.abs(sp[0, screws]).max()


def test_default_setting_error_against_the_tight_reference_is_far_below_the_model_error():
    horizon = 5.0
    t_ref, ref = reference_track(horizon, SHORT)
    _, r = run(TRAVERSE, SHORT, {"duration": horizon})
    assert r.summary["completed"]
    t, pose = tail_track(r)
    e = track_error(t, pose, t_ref, ref)
    assert e["pos_err_m"] < 0.1 * 0.04 and e["yaw_err_rad"] < 0.1 * 0.06, e
    # and the reference is a real motion, so the comparison is not trivially zero
    assert np.hypot(*(ref[-1, :2] - ref[0, :2])) > 0.05
