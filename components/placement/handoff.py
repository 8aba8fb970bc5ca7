"""Hand a settled, pre-loaded placement over to a hold run (paper 2.2.6: "the autonomy system then
takes over ... gravity is re-enabled").

``held_state`` reads off a placement run (assemblies/lib/placement-scene.yaml) at its last
sample: every DOF joint angle, the tail link's pose, and the settle component's latched
pre-load torques; the set-points are the angles themselves (the loaded shape).
``hold_overrides`` turns that into ``--set`` items for a hold scene
(assemblies/lib/placement-hold.yaml), which starts there at rest with gravity on.

Why two runs and not one: between walls the pre-load squeezes the robot into a shape whose
screws must slide ~F/k (≈ 1 mm at 100 N on the 1e5 N/m ice) along the walls to
carry the pre-load's frictionless distribution; with the regularised friction that slide
creeps at ≲ v_ε, i.e. seconds at the small v_ε a creep-free hold needs (and at high μ the
squeeze locks in a low-force state). The placement is a solver, not the experiment: it
settles and pre-loads with the terrain's own (low) friction, and the hold run starts from
its state with the wall friction under test. Same state for every μ: hold and slip
differ by the friction only.

Hold limit (an upright robot, gravity along its axis, every screw force along the wall
normal): the walls' friction can carry at most μ ΣF_n, so the robot slides unless
μ ≥ μ* = m g / ΣF_n (a necessary condition; with the regularised law it is also what
sets the steady creep: a rigid body sinking at v has friction μ ΣF_n v/sqrt(v² + v_ε²)
= m g, i.e. v = v_ε r/sqrt(1 − r²), r = μ*/μ). Below μ* the robot slides with
a = g (1 − μ/μ*) (friction saturated once v ≫ v_ε).
"""

from __future__ import annotations

import json

import numpy as np

from .settle import SettlePhase


def held_state(session, result, prefix: str = "placement-scene/") -> dict:
    """The placement run's loaded state as hold-scene parameters: q, pose (tail), setpoint and tau_ff
    (DOF joints in URDF order), nj. Read at the last sample of the loading phase (SettlePhase.LOADING: pre-load
    on, gravity still off), so the run may go on into its own hold. The run must record
    settle.phase, robot.joint_q, robot.link_poses and settle.tau_ff."""
    phase = np.asarray(result[prefix + "settle.phase"][:, 0])
    loading = np.flatnonzero(phase == SettlePhase.LOADING)
    if loading.size == 0:
        raise ValueError(f"held_state: the placement run has no loading phase (phase reached {phase.max():g}): "
                         "run it past the latch, with settle load_time > 0")
    i = int(loading[-1])
    q = np.asarray(result[prefix + "robot.joint_q"][i], float)
    tail = np.asarray(result[prefix + "robot.link_poses"][i], float).reshape(-1, 7)[0]
    tau = np.asarray(result[prefix + "settle.tau_ff"][i], float)
    return {"q": [float(v) for v in q],
            "pose": {"position": [float(v) for v in tail[:3]], "quaternion": [float(v) for v in tail[3:]]},
            "setpoint": [float(v) for v in q], "tau_ff": [float(v) for v in tau], "nj": len(q)}


def hold_overrides(state: dict) -> list[str]:
    """``--set`` items (load_session overrides) putting ``state`` into a hold scene."""
    return [f"{k}={json.dumps(v)}" for k, v in state.items()]
