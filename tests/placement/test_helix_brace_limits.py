"""Why EELS 1.5 cannot brace as a helix in the moulin's 0.5 m shaft (issue 15, moulin-down-climb): the placement
of placement-tube-helix.yaml (gravity off, settle onto the wall of vertical-tube-r0.5, then the pre-load).

A brace with gravity off must be self-equilibrated: wall forces F_s along the wall normals n_s (radial,
horizontal in a vertical tube) with Σ F_s n_s = 0 and Σ F_s p_s × n_s = 0. On a helix the moment rows
Σ F_s z_s (ẑ × n_s) tie the heights to the azimuths; the settle's non-negative least-squares balance
(components/placement/settle.py) finds none when the screws span ~260° (8 modules) and finds one once they
span more than a turn (12 modules, ~420°). That one must also carry the weight: friction holds at most
μ ΣF, so the pre-load scaled to ΣF = m g / μ sets the least joint torques the brace needs, compared here
with EELS 1.5's twist actuators' effort (40 N·m) at the walls scenes' μ = 1.5 (the moulin's ice: 0.1)."""

from __future__ import annotations

import numpy as np

from snakesim.components.placement import SettlePhase
from snakesim.framework.session import load_session

P = "placement-scene/"
MU = 1.5


def _place(modules: int, radius: float, pitch: float):
    shape = (f"shape={{kind: helix, radius: {radius}, pitch: {pitch}, phase: 0.0, "
             "pose: {position: [0.0, 0.0, 0.0], rpy: [0.0, -1.5707963267948966, 0.0]}}")
    s = load_session("placement-tube-helix", sim_overrides={"duration": 1.4},
                     overrides=[f"robot={{name: eels-1.5, modules: {modules}, head: null, urdf: null}}", shape])
    r = s.run()
    assert (np.asarray(r[P + "settle.phase"])[:, 0] >= SettlePhase.LOADING).any(), "did not settle"
    return s, r


def test_helix_under_one_turn_has_no_self_equilibrated_squeeze():
    s, r = _place(8, 0.43, 2.6)
    F = s.plan.caches[P + "settle"].preload_forces
    assert F.sum() < 1e-3 * 8 * s.plan.components[P + "settle"].p.preload


def test_helix_over_one_turn_squeezes_but_needs_more_twist_torque_than_eels_1_5_has():
    s, r = _place(12, 0.415, 2.2)
    robot = s.plan.components[P + "robot"].robot
    F = s.plan.caches[P + "settle"].preload_forces
    assert F.sum() > 0.5 * 12 * s.plan.components[P + "settle"].p.preload   # a squeeze exists
    phase = np.asarray(r[P + "settle.phase"])[:, 0]
    tau = np.asarray(r[P + "settle.tau_ff"])[np.flatnonzero(phase == SettlePhase.LOADING)[-1]]
    mg = sum(l.mass for l in robot.tree.links) * 9.81
    scale = mg / MU / F.sum()                                                 # least squeeze that holds
    twist = np.array(robot.joint_kinds) == "twist"
    need = np.abs(tau[twist]).max() * scale
    assert need > robot.effort_limits()[twist].max(), need
