"""EELS 1.5 (5 modules) braced across the 0.44 m vertical tube with every link colliding and joint stops on
(assemblies/tube-body-brace.yaml; issue 15: the tube hold).

Checks, each from the model:
- static balance: the tube's normals are horizontal, so the contact forces' vertical components (screws and
  bodies) are the friction carrying the weight: Σ F_z = m g within 2 % at every sample after the first second;
- the field test's hold: >= 10 s within the evaluation's 5 mm drift; the bracing screws stay loaded (the least
  at the regulated target, 10 %), the free screws 1 and 3 off the wall;
- no body deeper than 5 mm in the wall (terrain_clearance; the cross bar touches it, as a body may), every bend
  and twist inside its URDF limits, the joint stops on;
- the brace lies in one plane through the tube's axis (the placement's fit: `sides`, lean 0): the bracing
  screws' origins at azimuths φ, φ + π, φ (screws 0 and 4 on one side, 2 on the other) within 0.02 rad.
"""

from __future__ import annotations

import numpy as np
import pytest

from validation_scenes import assert_bodies_clear_and_within_limits, run

SCENE = "tube-body-brace"
BRACE, FREE = [0, 2, 4], [1, 3]


@pytest.fixture(scope="module")
def hold():
    s, r = run(SCENE)
    return s, r, s.plan.components["robot"].robot


def test_holds_ten_seconds_in_static_balance(hold):
    s, r, robot = hold
    T = r["t"]
    mg = sum(link.mass for link in robot.tree.links) * 9.81
    Fz = r["contact.wrenches"][:, 2::6].sum(axis=1) + r["body.wrenches"][:, 2::6].sum(axis=1)
    late = T >= 1.0
    np.testing.assert_allclose(Fz[late], mg, rtol=0.02)
    ev = r.summary["reports"]["evaluation"]
    assert ev["hold"]["achieved"] and ev["hold"]["longest_s"] >= 10.0 and not ev["failure"]["failed"]
    Fn = r["contact.screw_normal_force"]
    target = s.plan.components["brace"].p.target
    assert Fn[late][:, BRACE].min(axis=1).mean() == pytest.approx(target, rel=0.1)
    assert Fn[:, FREE].max() == 0.0


def test_no_body_in_the_wall_and_joints_within_limits(hold):
    s, r, robot = hold
    assert_bodies_clear_and_within_limits(s, r, robot)


def test_the_bracing_screws_lie_in_one_plane_through_the_axis(hold):
    s, r, robot = hold
    screws = robot.metadata["screws"]
    rows = [robot.links.index(screws[k]["link"]) for k in BRACE]
    P = r["robot.link_poses"].reshape(len(r["t"]), -1, 7)[0, rows, :3]
    azimuth = np.arctan2(P[:, 1], P[:, 0])
    d = np.angle(np.exp(1j * (azimuth - azimuth[0])))
    np.testing.assert_allclose(np.abs(d), [0.0, np.pi, 0.0], atol=0.02)   # screws 0, 4 together, 2 opposite


#: the seeded multi-start fit's best 5-module brace in the 0.44 m tube (bends only, sides {0: +1, 2: −1, 4: +1},
#: screws 1 mm short: fit_leaning_tube_brace(..., starts=8, kinds=("bend",), spacing=0.03)), refitted below
GUESS = {"q": [0.253143, 0.0, 0.0, 0.271028, 0.0, 0.0, 0.048211, 0.0, 0.0, -0.673897, 0.0, 0.0, 0.384553, 0.0, 0.0],
         "pose": {"position": [0.155214446, 0.012887461, 0.1],
                  "quaternion": [-0.705876652, -0.335026298, -0.592960079, 0.194663497]}}
TOTAL = 300.0       # N, ΣF_n of the scene's gravity pre-load


@pytest.fixture(scope="module")
def placed():
    """The fit from GUESS (the screws to the wall, in a plane through the axis), then placement-walls-body.yaml
    on the tube from it, then the gravity pre-load of the loaded state."""
    import json

    from snakesim.components.contact.robot_screws import screw_layout
    from snakesim.components.multibody.robot_model import RobotModel
    from snakesim.components.placement import SettlePhase
    from snakesim.components.placement.handoff import gravity_preload, held_state
    from snakesim.components.placement.tube_brace import fit_leaning_tube_brace
    from snakesim.components.terrain import load_terrain
    from snakesim.framework.session import load_session

    robot = RobotModel.load(design="eels-1.5", modules=5)
    tube = load_terrain("vertical-tube-r0.22")
    fit = fit_leaning_tube_brace(robot, tube, GUESS["q"], GUESS["pose"], BRACE, 0.0, depth=0.0, kinds=("bend",),
                                 spacing=0.03, sides={0: 1, 2: -1, 4: 1})
    shape = {"kind": "joints", "q": fit.q, "pose": fit.pose}
    s = load_session("placement-walls-body", overrides=["robot.modules=5", "terrain=vertical-tube-r0.22",
                                                        "shape=" + json.dumps(shape), "brace_screws=[0, 2, 4]"],
                     sim_overrides={"duration": 1.0})
    r = s.run()
    state = held_state(s, r, prefix="")
    i = int(np.flatnonzero(r["settle.phase"][:, 0] == SettlePhase.LOADING)[-1])
    settle = s.plan.components["settle"]
    n, pts = settle._envelope_points(r["robot.link_poses"][i].reshape(-1, 7), tube)
    lay = robot.derived(screw_layout)
    links = [robot.links[lay.parent_row[k]] for k in BRACE]
    tau, N, c = gravity_preload(robot, state, links, pts[BRACE], n[BRACE], TOTAL)
    return fit, s, r, i, state, robot, tau, N, c


def test_the_fit_reaches_the_wall_with_the_bodies_clear(placed):
    fit = placed[0]
    assert fit.feasible, fit
    assert max(abs(v) for v in fit.depth.values()) < 5e-4 and fit.overrun < 5e-4
    lo, hi = placed[5].position_limits()
    assert all(lo[k] < v < hi[k] for k, v in enumerate(fit.q))


def test_placement_squeezes_the_brace_self_equilibrated(placed):
    """Gravity off: Σ F n̂ = 0 for three contacts on one line through the axis: F0 + F4 = F2."""
    _, s, r, i, *_ = placed
    F = s.plan.caches["settle"].preload_forces
    assert F[0] > 0 and F[4] > 0 and F[1] == 0.0 and F[3] == 0.0
    assert F[0] + F[4] == pytest.approx(F[2], rel=1e-3)
    assert r.summary["reports"]["clearance"]["inside"] == {}


def test_scene_defaults_are_the_derived_state(placed):
    """tube-body-brace.yaml's q, pose and torque pattern are this placement's state and its gravity pre-load."""
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry

    _, _, _, _, state, robot, tau, N, c = placed
    scene = resolve(SCENE, search_path=default_registry().assembly_paths()).parameters
    np.testing.assert_allclose(scene["q"], state["q"], atol=2e-4)
    np.testing.assert_allclose(scene["pose"]["position"], state["pose"]["position"], atol=2e-4)
    assert abs(np.dot(scene["pose"]["quaternion"], state["pose"]["quaternion"])) == pytest.approx(1.0, abs=1e-6)
    for name, t in zip(robot.joints, tau):
        assert scene["torque_pattern"].get(name, 0.0) == pytest.approx(t, abs=0.5), name
    efforts = dict(zip(robot.joints, robot.effort_limits()))
    assert all(abs(t) <= efforts[n] for n, t in zip(robot.joints, tau))    # within the actuators
    assert c < 1.5                                                          # the friction it needs < μ
    assert scene["target"] < min(N)              # regulated below the pre-load's least load at A = 1
