"""Writes into the multibody's continuous state by meaning: the floating base's pose, joint positions, rest.

The multibody's continuous state (:class:`~.component.Multibody`) is Pinocchio's
``[q (nq), v (nv)]``, named by ``robot.q_names`` and ``robot.v_names``:

    q  root_joint.x, .y, .z          the root link's origin in the world, m
       root_joint.qx, .qy, .qz, .qw  the root link's orientation in the world (unit quaternion)
       <joint>                       a revolute DOF joint's angle, rad
       <joint>.cos, <joint>.sin      a continuous DOF joint's angle on the circle
    v  root_joint.vx … .wz           the root link's velocity (linear, angular), root-link axes
       <joint>                       a DOF joint's rate, rad/s

Each function returns ``(index, values)`` for
:meth:`StateEdit.write <snakesim.framework.state_edit.StateEdit.write>` (indices into the component's
own state); the values are exact (the quaternion is divided by its norm, nothing else is touched).
A ``ValueError`` names the offending field.
"""

from __future__ import annotations

import math

import numpy as np

from .model import ROOT_JOINT
from .robot_model import RobotModel

BASE_Q = tuple(f"{ROOT_JOINT}.{c}" for c in ("x", "y", "z", "qx", "qy", "qz", "qw"))
BASE_V = tuple(f"{ROOT_JOINT}.{c}" for c in ("vx", "vy", "vz", "wx", "wy", "wz"))


def base_pose(robot: RobotModel, position, quaternion) -> tuple[np.ndarray, np.ndarray]:
    """The root link's pose: ``position`` (x, y, z, m, world) and ``quaternion`` (x, y, z, w; normalised here)."""
    p = np.asarray(position, dtype=float).ravel()
    q = np.asarray(quaternion, dtype=float).ravel()
    if p.size != 3 or q.size != 4:
        raise ValueError(f"position needs 3 values and quaternion 4, got {p.size} and {q.size}")
    for name, vals in (("position", p), ("orientation", q)):
        for c, v in zip("xyz" if name == "position" else "xyzw", vals):
            if not math.isfinite(v):
                raise ValueError(f"{name}.{c} = {v} is not finite")
    n = float(np.sqrt(q @ q))
    if not n > 1e-9:
        raise ValueError(f"orientation has norm {n:g}: no rotation (a quaternion needs a direction)")
    return _q_index(robot, BASE_Q), np.concatenate([p, q / n])


def at_rest(robot: RobotModel) -> tuple[np.ndarray, np.ndarray]:
    """Every velocity (the base's and every joint's) zero."""
    return robot.nq + np.arange(robot.nv), np.zeros(robot.nv)


def joint_positions(robot: RobotModel, positions: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """DOF joints by URDF name to these angles (rad), their rates to zero."""
    index, values = [], []
    q_names, v_names = robot.q_names, robot.v_names
    for name, angle in positions.items():
        if name not in robot.dof_of:
            raise ValueError(f"'{name}' is not a DOF joint of {robot.label}")
        if not math.isfinite(angle):
            raise ValueError(f"{name} = {angle} is not finite")
        if name in q_names:
            index.append(q_names.index(name))
            values.append(float(angle))
        else:                                        # a continuous joint: (cos, sin)
            index += [q_names.index(f"{name}.cos"), q_names.index(f"{name}.sin")]
            values += [math.cos(angle), math.sin(angle)]
        index.append(robot.nq + v_names.index(name))
        values.append(0.0)
    return np.array(index, dtype=np.intp), np.array(values, dtype=float)


def _q_index(robot: RobotModel, names) -> np.ndarray:
    try:
        return np.array([robot.q_names.index(n) for n in names], dtype=np.intp)
    except ValueError:
        raise ValueError(f"{robot.label} has no floating base ({ROOT_JOINT}) to place") from None
