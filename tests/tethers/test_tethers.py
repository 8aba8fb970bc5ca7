"""Tethers: slack when compressed, k·stretch (+ damping) when stretched, never pushing; releasable
by schedule and by input; a body hanging from one oscillates at √(k/m) and falls once released."""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.tethers import Tethers, WrenchSum
from snakesim.framework import Harness
from snakesim.framework.registry import build_registry
from snakesim.framework.session import load_session

BODY = ('<robot name="bob"><link name="bob"><inertial><origin xyz="0 0 0"/><mass value="{m}"/>'
        '<inertia ixx="0.02" iyy="0.03" izz="0.04" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        '<link name="mark"/><joint name="mark_joint" type="fixed"><parent link="bob"/><child link="mark"/>'
        '<origin xyz="0.1 0 0"/></joint></robot>')


def _harness(urdf, **spec):
    t = {"link": "bob", "anchor": (0.0, 0.0, 2.0), "stiffness": 1000.0, "damping": 0.0, "rest_length": 1.0, **spec}
    h = Harness(Tethers, {"tethers": [t]}, uses={"robot": RobotModel.load(urdf=urdf)})
    nl = h.infos["link_poses"].shape[0]
    h.inputs.link_rotations = np.broadcast_to(np.eye(3), (nl, 3, 3))
    return h, nl


def _at(h, nl, z, vz=0.0, w=(0.0, 0.0, 0.0)):
    poses = np.zeros((nl, 7))
    poses[:, 2], poses[:, 6] = z, 1.0
    vel = np.zeros((nl, 6))
    vel[:, 2], vel[:, 3:] = vz, w
    h.inputs.link_poses, h.inputs.link_velocities = poses, vel
    return h.outputs()


def test_slack_when_compressed_spring_when_stretched_and_never_pushing():
    h, nl = _harness(BODY.format(m=1.0), damping=20.0, offset=(0.1, 0.0, 0.0))
    out = _at(h, nl, 1.5)                                   # 0.5 m from the anchor, rest length 1 m
    assert out["tension"][0] == 0.0 and not out["wrenches"].any()
    out = _at(h, nl, 0.7)                                   # length 1.3 + (offset): stretched
    ell = math.hypot(0.1, 1.3)
    T = 1000.0 * (ell - 1.0)
    assert out["length"][0] == pytest.approx(ell) and out["tension"][0] == pytest.approx(T)
    e = np.array([-0.1, 0.0, 1.3]) / ell
    np.testing.assert_allclose(out["wrenches"][0, :3], T * e)
    np.testing.assert_allclose(out["wrenches"][0, 3:], np.cross([0.1, 0.0, 0.0], T * e))
    out = _at(h, nl, 0.7, vz=-0.2)                          # moving away: the damper adds c·ℓ̇
    assert out["tension"][0] == pytest.approx(T + 20.0 * 0.2 * 1.3 / ell)
    out = _at(h, nl, 0.7, vz=+50.0)                         # snapping back fast: a rope cannot push
    assert out["tension"][0] == 0.0


def test_schedule_and_input_attach_and_release():
    h, nl = _harness(BODY.format(m=1.0), attach=1.0, release=2.0)
    poses = np.zeros((nl, 7))
    poses[:, 6] = 1.0
    h.inputs.link_poses = poses
    assert [h.outputs(t)["tension"][0] > 0 for t in (0.5, 1.0, 1.5, 2.0, 3.0)] == [False, True, True, False, False]
    h.inputs.attached = [1.0]
    assert h.outputs(3.0)["tension"][0] == pytest.approx(1000.0)
    h.inputs.attached = [0.0]
    assert h.outputs(1.5)["tension"][0] == 0.0
    bob = {"robot": RobotModel.load(urdf=BODY.format(m=1.0))}
    with pytest.raises(ValueError, match="not in the robot; links: bob, mark"):
        Tethers("t", {"tethers": [{"link": "arm", "anchor": (0, 0, 0), "rest_length": 1}]}, uses=bob)
    with pytest.raises(ValueError, match="release 1 s must come after attach 2 s"):
        Tethers("t", {"tethers": [{"link": "bob", "anchor": (0, 0, 0), "rest_length": 1, "attach": 2.0,
                                   "release": 1.0}]}, uses=bob)


def test_hanging_body_oscillates_at_sqrt_k_over_m_then_falls_when_released(tmp_path):
    m, k, g, t_rel = 2.0, 800.0, 9.81, 1.0
    (tmp_path / "bob.urdf").write_text(BODY.format(m=m))
    u = tmp_path / "bob.urdf"
    (tmp_path / "s.yaml").write_text(textwrap.dedent(f"""
        sim: {{duration: 1.5, dt: 0.0005, integrator: rk4}}
        components:
          robot: {{type: multibody, params: {{urdf: "{u}"}}}}
          rope:
            type: tethers
            params:
              tethers: [{{link: bob, anchor: [0, 0, 1.0], stiffness: {k}, damping: 0, rest_length: 1.0,
                          release: {t_rel}}}]
          both: {{type: wrench_sum}}
        connections:
          - robot.link_rotations -> rope.link_rotations
          - robot.link_poses -> rope.link_poses
          - robot.link_velocities -> rope.link_velocities
          - rope.wrenches -> both.u0
          - both.y -> robot.wrenches
        record: [robot.com, rope.tension]
    """))
    res = load_session(tmp_path / "s.yaml", registry=build_registry(load_entry_points=False)).run()
    t, z = res["t"], res["robot.com"][:, 2]
    w = math.sqrt(k / m)
    held = t <= t_rel
    # starts at rest at the rope's rest length: z = −(m g / k)(1 − cos ωt)
    np.testing.assert_allclose(z[held], -(m * g / k) * (1 - np.cos(w * t[held])), atol=1e-6 * m * g / k)
    after = t > t_rel + 1e-9
    z1 = -(m * g / k) * (1 - math.cos(w * t_rel))
    v1 = -(m * g / k) * w * math.sin(w * t_rel)
    dt = t[after] - t_rel
    # the release falls on a step boundary: RK4's last stage of the step ending there already sees
    # the rope gone, a velocity error of at most (h/6)·(T/m) that then grows linearly
    h = 0.0005
    dv = h / 6 * k * abs(z1) / m
    np.testing.assert_allclose(z[after], z1 + v1 * dt - 0.5 * g * dt ** 2, atol=1.2 * dv * dt.max() + 1e-6)
    assert not res["rope.tension"][after].any()


def test_wrench_sum_keeps_the_link_shape():
    h = Harness(WrenchSum, {"nl": 3, "signs": [1.0, -1.0]})           # no robot: nl given
    a, b = np.arange(18.0).reshape(3, 6), np.ones((3, 6))
    h.inputs.u0, h.inputs.u1 = a, b
    np.testing.assert_array_equal(h.outputs()["y"], a - b)
    robot = RobotModel.load(urdf=BODY.format(m=1.0))
    assert Harness(WrenchSum, {}, uses={"robot": robot}).infos["y"].shape == (robot.nl, 6)   # the robot's nl
    with pytest.raises(ValueError, match="give 'nl'"):
        WrenchSum("w", {})
