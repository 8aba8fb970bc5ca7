"""Conservation laws, run through the framework (assembly -> session -> integrator).

* A free-floating snake in zero gravity driven only by its own joint torques
  has no external force or torque on it: its total linear and angular
  momentum stay constant.
* A passive chain (no torques, no damping) in gravity conserves kinetic +
  potential energy; RK4 is not symplectic, so its energy error is set by its
  fourth-order truncation error: halving the step must shrink the drift by
  about 2^4 = 16.

The free-flyer's configuration lives on SE(3). Classical RK4 combining stage
derivatives at the step's start point is only second order there unless each
stage derivative is mapped back to the start point's chart (Munthe-Kaas,
``Multibody.dexp_inv``), which the framework's integrators do.
"""

from __future__ import annotations

import numpy as np
import pytest

from snake_models import snake_urdf

SCENE = """
sim: {{duration: {duration}, dt: {dt}, integrator: {integrator}}}
components:
  torque: {{type: sine, params: {{n: {nj}, amplitude: {amp}, frequency: 1.3, phase: 0.4}}}}
  robot:
    type: multibody
    params:
      urdf: {urdf}
      gravity: {gravity}
      screw_pairs: {mode}
      base_position: [0.3, -0.2, 0.5]
      base_yaw: 0.7
      base_velocity: [0.2, -0.1, 0.05, 0.3, -0.2, 0.4]
      q0: {{"bend_*": 0.3, "twist_*": -0.4}}
      v0: {v0}
connections:
  - torque.y -> robot.tau
record: [robot.momentum, robot.energy, robot.joint_v]
"""

NJ = 9  # bend, twist, screw pair (one DOF) per module, 3 modules
TORQUES = [3.0, -2.0, 1.5, 2.5, -1.0, 0.8, -2.0, 1.2, 0.6]


def _run(run_scene, tmp_path, urdf, *, mode="auto", gravity=(0, 0, 0), amp=None, duration=1.0, dt=1e-3,
         v0="{}", integrator="rk4"):
    path = tmp_path / "snake.urdf"
    path.write_text(urdf)
    amp = amp if amp is not None else [0.0] * NJ
    return run_scene(SCENE.format(urdf=path, gravity=list(gravity), mode=mode, amp=list(amp), duration=duration,
                                  dt=dt, v0=v0, nj=NJ, integrator=integrator))


def _momentum_drift(res):
    h = res["robot.momentum"]
    lin = np.abs(h[:, :3] - h[0, :3]).max() / np.linalg.norm(h[0, :3])
    ang = np.abs(h[:, 3:] - h[0, 3:]).max() / np.linalg.norm(h[0, 3:])
    return lin, ang


@pytest.mark.parametrize("mode", ["embedded", "mimic_crba"])
def test_momentum_conserved_under_internal_torques(run_scene, tmp_path, mode):
    urdf = snake_urdf(modules=3, screws="pair", twist=True)
    session, res = _run(run_scene, tmp_path, urdf, mode=mode, amp=TORQUES, v0='{"screw_*": 8.0, "bend_01": 0.5}')
    assert res.summary["completed"]
    assert session.plan.components["robot"].mode == mode
    # the motion is not trivial: the internal torques reshape the body
    assert np.ptp(res["robot.joint_v"], axis=0).max() > 0.5
    lin, ang = _momentum_drift(res)
    per_second = 1e-9 * res.summary["sim_time_s"]
    assert lin < per_second and ang < per_second, (lin, ang)


def test_rk4_keeps_order_four_on_the_free_flyer(run_scene, tmp_path):
    """With the Munthe-Kaas chart correction (Multibody.dexp_inv, called by the
    framework's RK4) the momentum error falls as h⁴: 16x per halving
    asymptotically; without it the free-flyer orientation makes it h² (4x)."""
    urdf = snake_urdf(modules=3, screws="pair", twist=True)
    drift = {}
    for dt in (2e-3, 1e-3):
        _, res = _run(run_scene, tmp_path, urdf, amp=TORQUES, dt=dt, duration=0.5)
        drift[dt] = max(_momentum_drift(res))
    assert drift[2e-3] / drift[1e-3] > 10.0, drift


TETHERED = """
sim: {{duration: 1.0, dt: {dt}, integrator: {integrator}}}
components:
  robot:
    type: multibody
    params:
      urdf: {urdf}
      q0: {{"bend_*": 0.4, "twist_*": 0.3}}
      v0: {{"screw_*": 10.0, "bend_01": 2.0}}
      damping: {{}}
  spring: {{type: test_anchor_spring, params: {{nl: {nl}, k: {k}}}}}
connections:
  - robot.link_poses -> spring.poses
  - spring.wrenches -> robot.wrenches
record: [robot.energy, robot.link_poses]
"""


def test_passive_chain_conserves_energy_to_rk4_order(run_scene, tmp_path):
    """A passive chain in gravity, its tail tethered to a world point by a linear spring.

    No torques, no damping: kinetic + gravity + spring energy is constant,
    up to the integrator's O(h⁴) error. The tether makes gravity do work on
    the joints (a free-falling chain would feel none); the spinning screws
    check that the embedded pairs keep their spin energy.
    """
    urdf = snake_urdf(modules=3, screws="pair", twist=True, head_mass=1.0)
    path = tmp_path / "snake.urdf"
    path.write_text(urdf)
    k, nl = 5000.0, urdf.count("<link ")
    drift = {}
    for dt in (2e-3, 1e-3):
        session, res = run_scene(TETHERED.format(dt=dt, urdf=path, nl=nl, k=k, integrator="rk4"))
        robot, spring = session.plan.components["robot"], session.plan.components["spring"]
        assert robot.mode == "embedded"
        e = res["robot.energy"]
        tail = res["robot.link_poses"][:, 7 * robot.link_index("tail"): 7 * robot.link_index("tail") + 7]
        total = e.sum(axis=1) + spring.potential(tail)
        # a real exchange between kinetic, gravity and spring energy is going on
        assert np.ptp(e[:, 0]) > 0.3 * e[:, 0].max() and np.ptp(e[:, 1]) > 0.3 * e[:, 0].max()
        drift[dt] = np.abs(total - total[0]).max() / e[:, 0].max()
    assert drift[1e-3] < 1e-8, drift
    ratio = drift[2e-3] / drift[1e-3]
    assert 10.0 < ratio < 24.0, (ratio, drift)


@pytest.mark.parametrize("method, order, bound", [("ros2", 2, 1e-2), ("ros34pw2", 3, 5e-5)])
def test_rosenbrock_w_keeps_momentum_to_its_order(run_scene, tmp_path, method, order, bound):
    """rosenbrock_w (the multibody's analytic block in W) keeps its order on the free flyer too:
    the momentum error falls as h^order per halving (the chart correction is applied to every
    stage). At 4 ms: 3.3e-3 of the momentum for ROS2, 1.6e-5 for ROS34PW2 (measured)."""
    urdf = snake_urdf(modules=3, screws="pair", twist=True)
    drift = {}
    for dt in (4e-3, 2e-3):
        integ = f"{{name: rosenbrock_w, params: {{method: {method}, step_control: fixed}}}}"
        _, res = _run(run_scene, tmp_path, urdf, amp=TORQUES, dt=dt, duration=0.5, integrator=integ)
        assert res.summary["completed"]
        drift[dt] = max(_momentum_drift(res))
    assert drift[4e-3] < bound, drift
    assert 0.7 * 2 ** order < drift[4e-3] / drift[2e-3] < 1.5 * 2 ** order, drift


def test_semi_implicit_euler_drifts_in_energy_at_first_order_on_a_multibody(run_scene, tmp_path):
    """Symplectic Euler keeps a shadow energy only for a separable Hamiltonian in canonical
    coordinates; a multibody's mass matrix depends on q and the method steps v, not momenta, so on
    the passive tethered chain the energy error is the method's first-order truncation error: it
    halves with the step (ratio 2 per halving, not the bounded oscillation of the linear
    oscillator, tests/framework/test_integrators.py)."""
    urdf = snake_urdf(modules=3, screws="pair", twist=True, head_mass=1.0)
    path = tmp_path / "snake.urdf"
    path.write_text(urdf)
    k, nl = 5000.0, urdf.count("<link ")
    drift = {}
    for dt in (2e-4, 1e-4):
        session, res = run_scene(TETHERED.format(dt=dt, urdf=path, nl=nl, k=k, integrator="semi_implicit_euler"))
        spring = session.plan.components["spring"]
        robot = session.plan.components["robot"]
        e = res["robot.energy"]
        tail = res["robot.link_poses"][:, 7 * robot.link_index("tail"): 7 * robot.link_index("tail") + 7]
        total = e.sum(axis=1) + spring.potential(tail)
        drift[dt] = np.abs(total - total[0]).max() / e[:, 0].max()
    ratio = drift[2e-4] / drift[1e-4]
    assert 1.6 < ratio < 2.5, (ratio, drift)
