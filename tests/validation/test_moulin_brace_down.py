"""moulin-brace-down (assemblies/moulin-brace-down.yaml: a vertical slot, terrains/moulin-slot.yaml) and its
inclined variant (moulin-brace-down-inclined.yaml, terrains/moulin-slot-inclined.yaml), shortened: EELS 1.5
braced across the slot section of a synthetic moulin holds still, then rolls down the slot.

Checked against the model, not the run's own printout: the hold from the recorded tail height; the descent
against the rolling law of walls-body-brace-down (every screw rolls without slip along the brace plane's
normal n, the robot translates at ω r along it, descending at ω r sin β with β = n's angle below the horizontal,
taken from the starting link positions; the drive ramps are symmetric, so the distance is
ω r sin β (climb_stop − climb_start)) and its direction (along n: diagonally down the vertical slot); the belay
tether's tension from its own record; no body inside the ice, no joint past its limit, no mobility failure."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.terrain import load_terrain
from snakesim.framework.session import load_session

HOLD, START, STOP = 2.0, 2.5, 6.5          # s: the short variant's hold, screws on, screws braked
SPEED = 6.0                                # rad/s, |climb_speed|
SCENES = {"moulin-brace-down": "moulin-slot", "moulin-brace-down-inclined": "moulin-slot-inclined"}


@pytest.fixture(scope="module", params=list(SCENES))
def run(request):
    s = load_session(request.param, overrides=[f"hold_time={HOLD}", f"climb_start={START}",
                                               f"climb_stop={STOP}", f"climb_speed={-SPEED}"],
                     sim_overrides={"duration": STOP + 2.5})
    r = s.run()
    names = [l.name for l in s.plan.components["robot"].robot.tree.links]
    t = np.asarray(r["t"])
    P = np.asarray(r["robot.link_poses"]).reshape(len(t), len(names), 7)[:, :, :3]
    return request.param, s, r, names, t, P


def test_the_shafts(run):
    scene = run[0]
    axis = load_terrain(SCENES[scene]).R[:, 2]                    # the shaft's upward axis
    if scene == "moulin-brace-down":
        assert axis == pytest.approx([0.0, 0.0, 1.0])             # a vertical moulin
    else:
        assert np.degrees(np.arcsin(axis[2])) == pytest.approx(31.8, abs=0.1)


def test_contact_then_a_static_hold(run):
    _, s, r, names, t, P = run
    ev = r.summary["reports"]["evaluation"]
    assert ev["contact"]["made"] and ev["contact"]["time_s"] == 0.0
    h = P[:, names.index("tail"), 2]
    before = t < START
    assert h[before].max() - h[before].min() < 0.005            # the evaluation's drift band
    assert ev["hold"]["achieved"] and ev["hold"]["longest_s"] >= HOLD


def test_descends_at_the_rolling_speed_along_the_brace_normal_with_the_tether_slack(run):
    _, s, r, names, t, P = run
    ev = r.summary["reports"]["evaluation"]
    radius = s.plan.components["robot"].robot.metadata["screws"][0]["radius"]
    # the brace plane: the chain's and screws' link origins at the start; n its normal, pointing down
    brace = [i for i, n in enumerate(names) if n.startswith(("tail", "knuckle_", "module_", "screw_"))]
    X = P[0, brace] - P[0, brace].mean(0)
    sv, n = np.linalg.svd(X)[1:]
    n = n[2] * -np.sign(n[2][2])
    assert sv[2] < 1e-2 * sv[1]                                    # a plane (the 3-point brace's)
    expected = SPEED * radius * -n[2] * (STOP - START)
    # the walls meander and change width by mm over metres (slopes <= 2 %): the rolling law holds to a few %;
    # the brace's creep (v_eps) adds < 1 mm
    assert ev["vertical_distance"]["down_m"] == pytest.approx(expected, rel=0.05)
    move = P[-1, names.index("tail")] - P[0, names.index("tail")]
    assert np.degrees(np.arccos(move @ n / np.linalg.norm(move))) < 2.0     # along n (the walls lean <= 0.9 deg)
    T = np.asarray(r["tether.tension"])
    assert T.max() <= 1.0 and ev["tether"]["slack"]              # the belay never carried load


def test_no_failure_no_body_in_the_ice_no_joint_past_its_limit(run):
    _, s, r, names, t, P = run
    rep = r.summary["reports"]
    assert not rep["evaluation"]["failure"]["failed"] and r.summary["stop_reason"] == "duration reached"
    assert rep["evaluation"]["max_tilt_deg"] < 60.0
    assert rep["clearance"]["inside"] == {}
    assert rep["limits"]["past_limits"] == {}
