"""EELS 1.5 braced between the 0.35 m walls with every link colliding (issue 15): placement, then a 10 ms hold.

No 4-screw C keeps EELS 1.5's bodies out of the 0.35 m gap; the 3-point C (screws 0 and 3 on the +y wall,
screw 2 on the −y wall, screw 1 free) does (assemblies/placement-walls-body.yaml). One placement run (gravity
off, attraction on the three bracing screws only: placement_settle ``screws``) gives the state; the hold
(assemblies/walls-body-brace.yaml, rosenbrock_w at 10 ms) starts there with gravity on and the pre-load that
carries the weight too (handoff.gravity_preload).

Checks, each from the model:
- the placement's pre-load is the self-equilibrated 3-point pattern: walls along ±y, so Σ F n̂ = 0 is
  F0 + F3 = F2, and screw 1 carries nothing; handoff.gravity_preload at g → 0 (Pinocchio point Jacobians)
  reproduces settle's virtual-work torques (its own lever arms), two independent derivations;
- the hold: static balance Σ F_z (screw + body contact) = m g within 2 % at every recorded sample after
  the first second; the screw loads are gravity_preload's (N_s, the same balance solved at the held shape);
  the sinking rate is the regularised friction's steady creep v_ε r/sqrt(1 − r²), r = m g/(μ ΣF_n), within
  10 %; the evaluation's hold achieved (drift < 5 mm over >= 10 s);
  no body deeper than 5 mm in a wall (terrain_clearance) and every bend inside its URDF limit;
- without the gravity term in the pre-load the same hold fails (screw 0 unloads): the test can fail;
- the same brace turned by −40° about the walls' normal (walls-body-brace-climb.yaml) holds, then climbs
  >= 1 m by rolling at ω r sin 40° (5 %), every bracing screw kept on its wall, no body in a wall.
"""

from pathlib import Path

import numpy as np
import pytest
import yaml

from scipy.spatial.transform import Rotation

from snakesim import assemblies

from snakesim.components.contact.robot_screws import screw_layout
from snakesim.components.placement import SettlePhase
from snakesim.components.placement.handoff import gravity_preload, held_state, hold_overrides
from snakesim.components.terrain import load_terrain
from snakesim.framework.session import load_session

MU, V_EPS, T_HOLD, TOTAL = 1.5, 2e-4, 12.0, 500.0
BETA, TOTAL_TURNED = np.radians(-40.0), 650.0       # walls-body-brace-climb.yaml
BRACE = [0, 2, 3]


@pytest.fixture(scope="module")
def placed():
    s = load_session("placement-walls-body", sim_overrides={"duration": 1.0})
    r = s.run()
    state = held_state(s, r, prefix="")
    i = int(np.flatnonzero(r["settle.phase"][:, 0] == SettlePhase.LOADING)[-1])
    settle = s.plan.components["settle"]
    robot = settle.robot
    n, pts = settle._envelope_points(r["robot.link_poses"][i].reshape(-1, 7), load_terrain("parallel-walls-0.35"))
    lay = robot.derived(screw_layout)
    links = [robot.links[lay.parent_row[k]] for k in BRACE]

    def preload(g, beta=0.0, total=TOTAL):
        """gravity_preload of the held state, turned by beta (rad) about world y through the centre of mass:
        (pose, tau, N, c)."""
        com, Ry = r["robot.com"][i], Rotation.from_rotvec([0.0, beta, 0.0])
        pose = {"position": list(Ry.apply(np.array(state["pose"]["position"]) - com) + com),
                "quaternion": list((Ry * Rotation.from_quat(state["pose"]["quaternion"])).as_quat())}
        p_w, n_w = Ry.apply(pts[BRACE] - com) + com, Ry.apply(n[BRACE])
        return (pose, *gravity_preload(robot, {**state, "pose": pose}, links, p_w, n_w, total, gravity=(0.0, 0.0, -g)))

    return s, r, i, state, robot, lambda g: preload(g)[1:], preload


def run_hold(state, tau_ff, duration=T_HOLD):
    over = hold_overrides({**state, "tau_ff": tau_ff}) + [f"friction={MU}", f"v_eps={V_EPS}"]
    s = load_session("walls-body-brace", overrides=over, sim_overrides={"duration": duration})
    return s, s.run()


@pytest.fixture(scope="module")
def held(placed):
    _, _, _, state, robot, preload, _ = placed
    tau, N, c = preload(9.81)
    s, r = run_hold(state, tau)
    return s, r, robot, N, c


def test_placement_preloads_the_three_bracing_screws_self_equilibrated(placed):
    s, r, i, state, robot, preload, _ = placed
    F_pre = s.plan.caches["settle"].preload_forces
    assert F_pre[1] == 0.0
    assert F_pre[0] + F_pre[3] == pytest.approx(F_pre[2], rel=1e-3)          # Σ F n̂ = 0 along y
    F = r["contact.screw_normal_force"][i]                                     # end of loading, gravity off
    np.testing.assert_allclose(F[BRACE], F_pre[BRACE], rtol=0.05)
    assert F[1] == 0.0 and r["body.normal_force"][i, 0] == 0.0                # screw 1 and every body clear
    tau0, N0, c0 = preload(1e-9)                                               # g → 0: settle's own pre-load
    assert c0 < 1e-3                      # only the µm-scale moment about the normal for friction to carry
    np.testing.assert_allclose(N0 * F_pre[BRACE].sum() / N0.sum(), F_pre[BRACE], rtol=0.05)
    # settle's virtual-work torques at the same (loaded) shape, scaled to the same total load
    settle = s.plan.components["settle"]
    tau_s, F_s = settle._preload_torques(r["robot.link_poses"][i].reshape(-1, 7), load_terrain("parallel-walls-0.35"))
    bends = [k for k, kind in enumerate(robot.joint_kinds) if kind == "bend"]
    np.testing.assert_allclose(np.array(tau0)[bends], tau_s[bends] * TOTAL / F_s.sum(), rtol=1e-3, atol=1e-3)


def test_scene_defaults_are_the_derived_state(placed):
    """walls-body-brace.yaml's q and tau_ff are this placement's state and gravity_preload (not stale)."""
    _, _, _, state, _, preload, _ = placed
    scene = yaml.safe_load((Path(assemblies.__file__).parent / "walls-body-brace.yaml").read_text())["parameters"]
    np.testing.assert_allclose(scene["q"], state["q"], atol=2e-4)
    np.testing.assert_allclose(scene["tau_ff"], preload(9.81)[0], atol=0.5)


def test_holds_ten_seconds_at_10ms_in_static_balance(held):
    s, r, robot, N, c = held
    T = r["t"]
    mass = sum(l.mass for l in robot.tree.links)
    mg = mass * 9.81
    Fz = r["contact.wrenches"][:, 2::6].sum(axis=1) + r["body.wrenches"][:, 2::6].sum(axis=1)
    late = T >= 1.0
    np.testing.assert_allclose(Fz[late], mg, rtol=0.02)
    Fn = r["contact.screw_normal_force"]
    np.testing.assert_allclose(Fn[late][:, BRACE].mean(axis=0), N, rtol=0.05)
    assert Fn[:, 1].max() == 0.0
    # steady creep of the regularised friction (handoff.py): every contact at r = m g/(μ ΣF_n),
    # v = v_ε r/sqrt(1 − r²)
    rr = mg / (MU * Fn[late][:, BRACE].sum(axis=1).mean())
    assert rr < 1.0
    z = r["robot.com"][:, 2]
    rate = -np.polyfit(T[late], z[late], 1)[0]
    assert rate == pytest.approx(V_EPS * rr / np.sqrt(1 - rr * rr), rel=0.1)
    ev = r.summary["reports"]["evaluation"]
    assert ev["hold"]["achieved"] and ev["hold"]["longest_s"] >= 10.0
    assert not ev["failure"]["failed"]


def test_no_link_inside_the_walls_and_bends_within_limits(held):
    s, r, robot, _, _ = held
    cl = r.summary["reports"]["clearance"]
    assert cl["inside"] == {} and cl["max_depth_m"] <= 0.005
    q = r["robot.joint_q"]
    for k, (name, kind) in enumerate(zip(robot.joints, robot.joint_kinds)):
        if kind == "bend":
            lim = robot.tree.joint_by_name[name]
            assert lim.lower <= q[:, k].min() and q[:, k].max() <= lim.upper, name


def test_without_the_gravity_preload_the_brace_lets_go(placed):
    """The placement's self-equilibrated pre-load (right with gravity off) cannot hold the weight's moments:
    screw 0 unloads within the first second and the robot slips."""
    state = placed[3]
    s, r = run_hold(state, state["tau_ff"], duration=1.0)
    F0 = r["contact.screw_normal_force"][:, 0]
    assert F0.min() < 0.1 * F0[0]


def scene_parameters(name):
    return yaml.safe_load((Path(assemblies.__file__).parent / name).read_text())["parameters"]


def test_turned_scene_defaults_are_the_derived_state(placed):
    """walls-body-brace-climb.yaml's pose and torque pattern: the held state turned by −40° about the walls'
    normal through the centre of mass, and its gravity pre-load at ΣF_n = 650 N (not stale)."""
    state, robot, turned = placed[3], placed[4], placed[6]
    pose, tau, N, c = turned(9.81, BETA, TOTAL_TURNED)
    scene = scene_parameters("walls-body-brace-climb.yaml")
    np.testing.assert_allclose(scene["pose"]["position"], pose["position"], atol=2e-4)
    np.testing.assert_allclose(np.abs(np.dot(scene["pose"]["quaternion"], pose["quaternion"])), 1.0, atol=1e-6)
    np.testing.assert_allclose(scene["q"], state["q"], atol=2e-4)
    pattern = scene["torque_pattern"]
    for name, t in zip(robot.joints, tau):
        assert pattern.get(name, 0.0) == pytest.approx(t, abs=0.5), name
    assert c < 0.75 * MU                       # the turned brace's friction need, with margin under μ


@pytest.fixture(scope="module", params=["walls-body-brace-climb", "walls-body-brace-down"])
def climbed(request):
    s = load_session(request.param)
    return s, s.run()


def test_turned_brace_holds_then_climbs_by_rolling(climbed):
    """Hold >= 10 s in static balance, then the screws roll (opposite senses on the two walls) and the robot
    translates along the turned brace plane's normal at ω r (walls-brace-climb.yaml): climbs (or, screws
    reversed, descends) at ω r sin 40°."""
    s, r = climbed
    p = scene_parameters(f"{Path(s.resolved.source).name}")
    robot = s.plan.components["robot"].robot
    mg = sum(l.mass for l in robot.tree.links) * 9.81
    T = r["t"]
    hold = (T >= 1.0) & (T <= p["climb_start"] - 0.5)
    Fz = r["contact.wrenches"][:, 2::6].sum(axis=1) + r["body.wrenches"][:, 2::6].sum(axis=1)
    np.testing.assert_allclose(Fz[hold], mg, rtol=0.02)
    ev = r.summary["reports"]["evaluation"]
    assert ev["hold"]["achieved"] and not ev["failure"]["failed"]
    # up at least 1 m, or down at least 1.5 m (paper 4.3.1: EELS 1.5 down-climbed over 1.5 m)
    net = ev["vertical_distance"]["net_m"]
    assert net >= 1.0 if p["climb_speed"] > 0 else net <= -1.5
    assert ev["max_tilt_deg"] < 60.0
    radius = robot.derived(screw_layout).radius[0]
    steady = (T >= p["climb_start"] + p["spin_up"] + 0.2) & (T <= p["climb_stop"] - 0.2)
    com = r["robot.com"]
    rate_z, rate_x = np.polyfit(T[steady], com[steady, 2], 1)[0], np.polyfit(T[steady], com[steady, 0], 1)[0]
    v = p["climb_speed"] * radius
    assert rate_z == pytest.approx(v * np.sin(-BETA), rel=0.05)
    assert np.hypot(rate_x, rate_z) == pytest.approx(abs(v), rel=0.05)
    # the brace holds on all the way: every bracing screw above the controller's lost fraction of the target
    F = r["contact.screw_normal_force"][T >= 1.0][:, BRACE]
    assert F.min() > 0.2 * p["target"]


def test_turned_brace_keeps_links_out_of_the_walls_and_bends_within_limits(climbed):
    s, r = climbed
    robot = s.plan.components["robot"].robot
    cl = r.summary["reports"]["clearance"]
    assert cl["inside"] == {} and cl["max_depth_m"] <= 0.005
    q = r["robot.joint_q"]
    for k, (name, kind) in enumerate(zip(robot.joints, robot.joint_kinds)):
        if kind == "bend":
            j = robot.tree.joint_by_name[name]
            assert j.lower <= q[:, k].min() and q[:, k].max() <= j.upper, name


def test_settle_rejects_unknown_brace_screws():
    with pytest.raises(Exception, match="params.screws"):
        load_session("placement-walls-body", overrides=["brace_screws=[0, 7]"])
