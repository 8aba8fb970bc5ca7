"""The multibody's own per-joint values: rotor armature, viscous damping, the initial state.

Functions of the robot (:class:`~.robot_model.RobotModel`) and the multibody's
params, evaluated once in ``Multibody.setup()``; joints are named exactly or by
glob pattern (``{"screw_*": 0.01}``), and a key that matches nothing is an
error listing the joints.
"""

from __future__ import annotations

import math

import numpy as np

from .model import match_values
from .robot_model import joint_kind
from .urdf import MultibodyModelError

#: Default reflected rotor inertia per joint kind, kg·m² per N·m of the joint's URDF effort limit.
#: A geared actuator's reflected inertia J_m·N² and peak torque T_m·N scale together:
#: J/T = (J_m/T_m)·N ≈ 2e-3 s² for harmonic-drive bend/twist actuators (BLDC J_m/T_m ~ 2e-5 s²,
#: N ~ 100) and hobby servos alike, less for the lower-ratio screw drives. Joints without an
#: effort limit get armature_floor.
ARMATURE_PER_EFFORT = {"bend": 2e-3, "twist": 2e-3, "screw": 7e-4, "other": 1e-3}


def armature(robot, p) -> dict[str, float]:
    explicit = match_values(robot.joints, p.armature, "armature")
    per_kind = {**ARMATURE_PER_EFFORT, **p.armature_per_effort}
    unknown = set(per_kind) - set(ARMATURE_PER_EFFORT)
    if unknown:
        raise MultibodyModelError(f"armature_per_effort: unknown joint kind(s) {sorted(unknown)}; "
                                  "kinds: bend, twist, screw, other")
    out = {}
    for name in robot.joints:
        if name in explicit:
            out[name] = explicit[name]
            continue
        per = per_kind[joint_kind(name)]
        out[name] = max(p.armature_floor, per * robot.tree.joint_by_name[name].effort)
    bad = {k: v for k, v in out.items() if not (v >= 0 and math.isfinite(v))}
    if bad:
        raise MultibodyModelError(f"armature must be finite and >= 0: {bad}")
    return out

def damping(robot, p) -> dict[str, float]:
    out = match_values(robot.joints, p.damping, "damping")
    bad = {k: v for k, v in out.items() if not (v >= 0 and math.isfinite(v))}
    if bad:
        raise MultibodyModelError(f"damping must be finite and >= 0: {bad}")
    return out

def _joint_values(robot, spec, what: str) -> dict[str, float]:
    if isinstance(spec, dict):
        return match_values(robot.joints, spec, what)
    if len(spec) != robot.nj:
        raise MultibodyModelError(f"{what}: a vector needs {robot.nj} values (DOF joints {', '.join(robot.joints)}), "
                                  f"got {len(spec)}")
    return dict(zip(robot.joints, map(float, spec)))

def initial_state(robot, p, model) -> np.ndarray:
    import pinocchio as pin

    q = pin.neutral(model)
    q[:3] = p.base_position
    if p.base_quaternion is not None:
        quat = np.array(p.base_quaternion, dtype=float)
        n = np.linalg.norm(quat)
        if not (n > 1e-9 and np.isfinite(n)):
            raise MultibodyModelError(f"base_quaternion {p.base_quaternion} has no direction (norm {n:g})")
        quat /= n
    else:
        quat = np.array([0.0, 0.0, math.sin(p.base_yaw / 2), math.cos(p.base_yaw / 2)])
    q[3:7] = quat
    for name, angle in _joint_values(robot, p.q0, "q0").items():
        jm = model.joints[model.getJointId(name)]
        if jm.nq == 2:
            q[jm.idx_q], q[jm.idx_q + 1] = math.cos(angle), math.sin(angle)
        else:
            q[jm.idx_q] = angle
    v = np.zeros(model.nv)
    rot = pin.Quaternion(quat[3], quat[0], quat[1], quat[2]).toRotationMatrix()
    bv = np.array(p.base_velocity, dtype=float)
    v[:3], v[3:6] = rot.T @ bv[:3], rot.T @ bv[3:]
    for name, rate in _joint_values(robot, p.v0, "v0").items():
        v[model.joints[model.getJointId(name)].idx_v] = rate
    x = np.concatenate([q, v])
    if not np.all(np.isfinite(x)):
        raise MultibodyModelError(f"initial state is not finite: {x}")
    return x

def check_mass_matrix(robot, dyn, owner: str) -> None:
    """Every DOF must carry inertia (mass below it or armature), or ABA divides by zero."""
    import pinocchio as pin

    m = pin.crba(dyn.model, dyn.data, pin.neutral(dyn.model))
    diag = np.diag(m)
    bad = [robot.v_names[i] for i in range(6, dyn.model.nv) if not diag[i] > 1e-12 * max(1.0, diag.max())]
    if bad:
        raise MultibodyModelError(f"{owner}: joint(s) {', '.join(bad)} move no mass and have no armature; "
                                  "give them armature (params.armature) or mass")
