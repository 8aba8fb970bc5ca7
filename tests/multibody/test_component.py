"""The component as the framework sees it: ports, feedthrough, gravity input, parameters, robots."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from snake_models import make_harness, random_state, set_state, snake_urdf
from snakesim.components.multibody import Multibody, MultibodyModelError
from snakesim.framework import Component, Input, Output, Params
from snakesim.framework.errors import BuildError, ConfigError
from snakesim.robots import DESIGNS, load_robot


# -- ports and feedthrough -----------------------------------------------------------------

class TailParams(Params):
    n_in: int
    n_out: int


class Tail(Component[TailParams]):
    """y = -u[-n_out:] (a stand-in controller, feedthrough)."""

    type_name = "test_tail_select"
    Params = TailParams
    u = Input(shape="n_in", unit=None)
    y = Output(shape="n_out", unit=None, feedthrough=True)

    def output(self, t, x, u, y):
        y.y[:] = -u.u[-self.p.n_out:]


LOOP = """
sim: {{duration: 0.01, dt: 0.001}}
components:
  robot: {{type: multibody, params: {{urdf: {urdf}}}}}
  ctrl: {{type: test_tail_select, params: {{n_in: {n}, n_out: 4}}}}
connections:
  - robot.{src} -> ctrl.u
  - ctrl.y -> robot.tau
"""


def test_state_outputs_do_not_feed_through_but_accelerations_do(run_scene, registry, tmp_path):
    """A controller reading joint angles or rates and driving torques is no algebraic loop; one
    reading accelerations (which depend on the torques) is."""
    registry.add_component(Tail)
    path = tmp_path / "s.urdf"
    path.write_text(snake_urdf(modules=2, screws="front"))            # 4 DOF joints, nv = 10
    for src, n in (("joint_q", 4), ("joint_v", 4), ("v", 10), ("q", 13)):
        session, res = run_scene(LOOP.format(urdf=path, n=n, src=src))
        assert res.summary["completed"]
    with pytest.raises(BuildError, match="algebraic loop"):
        run_scene(LOOP.format(urdf=path, n=10, src="a"))


def test_port_names_and_orders():
    urdf = snake_urdf(modules=2, screws="pair", twist=True)
    h = make_harness(urdf)
    c = h.c
    assert c.robot.links[:4] == ("tail", "knuckle_00", "module_00", "screw_front_link_00")   # URDF <link> order
    assert c.robot.joints == ("bend_00", "twist_00", "screw_front_00", "bend_01", "twist_01", "screw_front_01")
    names = Multibody.outputs["joint_q"].signal.element_names(c)
    assert names == tuple(c.robot.joints)
    assert Multibody.outputs["link_poses"].signal.element_names(c)[:7] == ("tail.x", "tail.y", "tail.z", "tail.qx",
                                                                    "tail.qy", "tail.qz", "tail.qw")
    out = h.outputs()
    assert out["q"].shape == (c.dyn.model.nq,) and out["link_velocities"].shape == (len(c.robot.links), 6)


GRAVITY_SWITCH = """
sim: {{duration: 0.4, dt: 0.001, integrator: rk4}}
components:
  g_on: {{type: step, params: {{initial: 1.0, value: 0.0, t_step: 0.2}}}}
  robot: {{type: multibody, params: {{urdf: {urdf}, gravity: [0, 0, -3.0]}}}}
connections: [g_on.y -> robot.gravity]
record: [robot.momentum]
"""


def test_gravity_switches_off_during_a_run(run_scene, tmp_path):
    """Momentum grows at M·g while gravity is on and stays constant once it is switched off."""
    urdf = snake_urdf(modules=2, screws="pair")
    path = tmp_path / "s.urdf"
    path.write_text(urdf)
    session, res = run_scene(GRAVITY_SWITCH.format(urdf=path))
    mass = sum(ln.mass for ln in session.plan.components["robot"].robot.tree.links)
    t, pz = res["t"], res["robot.momentum"][:, 2]
    on, off = t <= 0.2 - 1e-9, t >= 0.2 + 1e-3
    np.testing.assert_allclose(pz[on], -3.0 * mass * t[on], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(pz[off], pz[off][0], atol=1e-9)


def test_gravity_input_scale_and_vector():
    urdf = snake_urdf(modules=1, screws="front")
    h = make_harness(urdf, gravity=(0.0, 0.0, -9.81))
    tail = h.c.link_index("tail")
    assert np.allclose(h.outputs()["link_accelerations"][tail, :3], [0, 0, -9.81])   # unconnected: params
    h.inputs.gravity = [0.0]
    assert np.abs(h.outputs()["link_accelerations"]).max() < 1e-12
    h.inputs.gravity = [1.0 / 6.0]
    assert np.allclose(h.outputs()["link_accelerations"][:, :3], [0, 0, -9.81 / 6.0])
    hv = make_harness(urdf, gravity_input="vector")
    hv.inputs.gravity = [1.0, 2.0, -3.0]
    assert np.allclose(hv.outputs()["link_accelerations"][:, :3], [1.0, 2.0, -3.0])


def test_quaternion_and_continuous_joints_stay_on_their_manifolds(run_scene, tmp_path):
    path = tmp_path / "s.urdf"
    path.write_text(snake_urdf(modules=2, screws="pair", twist=True))
    scene = f"""
    sim: {{duration: 3.0, dt: 0.002, integrator: rk4}}
    components:
      robot:
        type: multibody
        params: {{urdf: {path}, gravity: [0, 0, 0], base_velocity: [0, 0, 0, 3.0, -2.0, 4.0],
                  v0: {{"screw_*": 20.0, "bend_*": 1.0}}}}
    record: [robot.q]
    """
    session, res = run_scene(scene)
    q = res["robot.q"][-1]
    model = session.plan.components["robot"].dyn.model
    assert abs(np.linalg.norm(q[3:7]) - 1.0) < 1e-13
    for jid in range(2, model.njoints):
        jm = model.joints[jid]
        if jm.nq == 2:
            assert abs(np.hypot(q[jm.idx_q], q[jm.idx_q + 1]) - 1.0) < 1e-13


# -- parameters ------------------------------------------------------------------------------

def test_initial_pose_and_joint_values():
    urdf = snake_urdf(modules=2, screws="pair", twist=True)
    h = make_harness(urdf, base_position=(1.0, 2.0, 3.0), base_yaw=np.pi / 2, q0={"bend_*": 0.2, "twist_01": -0.3},
                     v0=[0.1, 0.2, 5.0, 0.3, 0.4, -5.0], base_velocity=(1.0, 0.0, 0.0, 0.0, 0.0, 0.5))
    out = h.outputs()
    c = h.c
    np.testing.assert_allclose(out["joint_q"], [0.2, 0.0, 0.0, 0.2, -0.3, 0.0], atol=1e-15)
    np.testing.assert_allclose(out["joint_v"], [0.1, 0.2, 5.0, 0.3, 0.4, -5.0])
    tail = c.link_index("tail")
    np.testing.assert_allclose(out["link_poses"][tail], [1, 2, 3, 0, 0, np.sqrt(0.5), np.sqrt(0.5)], atol=1e-15)
    np.testing.assert_allclose(out["link_velocities"][tail], [1, 0, 0, 0, 0, 0.5], atol=1e-15)   # world axes


def test_armature_and_damping_by_name_pattern_and_kind():
    urdf = snake_urdf(modules=2, screws="front", twist=True)
    h = make_harness(urdf, armature={"bend_01": 0.5, "twist_*": 0.2}, damping={"screw_*": 0.05})
    c = h.c
    from snakesim.components.multibody.joint_values import ARMATURE_PER_EFFORT as per
    assert c.armature_user["bend_01"] == 0.5 and c.armature_user["twist_00"] == 0.2
    assert c.armature_user["bend_00"] == pytest.approx(per["bend"] * 100.0)       # URDF effort 100 N·m
    assert c.armature_user["screw_front_00"] == pytest.approx(per["screw"] * 30.0)
    assert c.damping_user == {"screw_front_00": 0.05, "screw_front_01": 0.05}


@pytest.mark.parametrize("params, match", [
    ({}, "give 'urdf'"),
    ({"urdf": "/nonexistent/robot.urdf"}, "does not exist"),
    ({"urdf": snake_urdf(1).replace('type="continuous"', 'type="prismatic"', 1)}, "prismatic"),
    ({"urdf": snake_urdf(1), "q0": {"bend_07": 0.1}}, "bend_07"),
    ({"urdf": snake_urdf(1), "q0": [0.1]}, "needs 2 values"),
    ({"urdf": snake_urdf(1), "base_quaternion": (0, 0, 0, 0)}, "no direction"),
    ({"urdf": snake_urdf(1), "armature": {"bend_00": 0.0, "screw_*": 0.0}, "armature_floor": 0.0}, None),
    ({"urdf": "<robot><link name='a'/><link name='b'/><joint name='j' type='revolute'><parent link='a'/>"
              "<child link='b'/><axis xyz='0 0 1'/></joint></robot>", "armature_floor": 0.0}, "move no mass"),
    ({"design": "eels-9"}, "unknown robot design"),
    ({"design": "eels-1.0", "urdf": "<robot/>"}, "path to a user URDF"),
])
def test_bad_parameters_name_the_problem(params, match):
    if match is None:           # zero armature is fine where the joint moves mass
        make_harness(**params)
        return
    with pytest.raises((MultibodyModelError, ValueError), match=match):
        make_harness(**params)


def test_a_cut_that_matches_nothing_lists_the_joints():
    robot = make_harness(snake_urdf(1)).c.robot
    with pytest.raises(MultibodyModelError, match="'nope' matches no joint or link.*joints: .*bend_00"):
        robot.cuts(["nope"])


def test_bad_parameters_surface_as_config_errors_in_a_scene(run_scene):
    with pytest.raises(ConfigError, match="components.robot"):
        run_scene("""
        components:
          robot: {type: multibody, params: {design: eels-1.0, modules: 2, q0: {elbow: 1.0}}}
        """)


# -- the robot designs (snakesim.robots) ------------------------------------------------------

@pytest.mark.parametrize("design", sorted(DESIGNS))
def test_every_design_builds_and_runs(design):
    h = make_harness(design=design, modules=2)
    c = h.c
    desc = load_robot(design, modules=2)
    has_pairs = "<mimic" in desc.urdf
    assert c.mode == ("embedded" if has_pairs else "plain")
    model = c.dyn.model
    rng = np.random.default_rng(0)
    q, v = random_state(model, rng)
    set_state(h, q, v, tau=rng.standard_normal(len(c.robot.joints)))
    dx = h.derivative()
    assert np.all(np.isfinite(dx))
    rep = c.optimisation_report(timing=False)
    assert rep["before"]["links"] == desc.urdf.count("<link ")
    assert rep["after"]["dof"] == model.nv and rep["after"]["bodies"] == model.njoints - 1
    assert rep["after"]["bodies"] + rep["after"]["links_as_frames"] == rep["before"]["links"]
    assert "before" in str(rep)
    if design == "eels-1.5":
        assert c.robot.cuts(["fts_joint_*"])[0] == [f"fts_joint_{i:02d}" for i in range(1, 2)]


@pytest.mark.parametrize("urdf", [snake_urdf(modules=2, screws="pair", twist=True, head_mass=1.0),
                                  load_robot("eels-1.5", modules=4).urdf],        # fixed joints mid-chain
                         ids=["leaf_frames", "eels-1.5"])
def test_report_unoptimised_crba_baseline_has_the_same_dynamics(urdf):
    """The locked-hinge baseline keeps every link a body yet must not change the motion."""
    from snakesim.components.multibody.report import baseline_models

    h = make_harness(urdf, screw_pairs="mimic_crba")
    base = baseline_models(h.c.robot.tree, h.c.armature_user)["crba"]
    opt = h.c.dyn
    assert base.model.njoints > opt.model.njoints and base.model.nv == opt.model.nv
    rng = np.random.default_rng(1)
    q, v = random_state(opt.model, rng)
    tau = rng.standard_normal(opt.model.nv)
    qb = pin.neutral(base.model)
    vb, tb = np.zeros(base.model.nv), np.zeros(base.model.nv)
    for jid in range(1, opt.model.njoints):
        jo, jb = opt.model.joints[jid], base.model.joints[base.model.getJointId(opt.model.names[jid])]
        qb[jb.idx_q:jb.idx_q + jo.nq] = q[jo.idx_q:jo.idx_q + jo.nq]
        vb[jb.idx_v:jb.idx_v + jo.nv], tb[jb.idx_v:jb.idx_v + jo.nv] = v[jo.idx_v:jo.idx_v + jo.nv], tau[jo.idx_v:jo.idx_v + jo.nv]
    a_opt, a_base = opt.forward(q, v, tau), base.forward(qb, vb, tb)
    for jid in range(1, opt.model.njoints):
        jo, jb = opt.model.joints[jid], base.model.joints[base.model.getJointId(opt.model.names[jid])]
        np.testing.assert_allclose(a_base[jb.idx_v:jb.idx_v + jo.nv], a_opt[jo.idx_v:jo.idx_v + jo.nv], atol=1e-10)
