"""The multibody's own per-joint values: rotor armature, viscous damping, the initial state.

Functions of the robot (:class:`~.robot_model.RobotModel`) and the multibody's
params, evaluated once in ``Multibody.setup()``; joints are named exactly or by
glob pattern (``{"screw_*": 0.01}``), and a key that matches nothing is an
error listing the joints.
"""

from __future__ import annotations

import math

import numpy as np

from snakesim.robots.designs import GEARED_ARMATURE_PER_EFFORT

from .model import match_values
from .robot_model import joint_kind
from .urdf import MultibodyModelError

#: Default reflected rotor inertia per joint kind, kg·m² per N·m of the joint's URDF effort limit, for a
#: robot that is not a snakesim.robots design (a bare URDF); a design carries its own
#: (``Design.armature_per_effort``). Joints without an effort limit get armature_floor.
ARMATURE_PER_EFFORT = dict(GEARED_ARMATURE_PER_EFFORT)


def armature(robot, p) -> dict[str, float]:
    return {name: value for name, (value, _) in armature_sources(robot, p).items()}


def armature_sources(robot, p) -> dict[str, tuple[float, str]]:
    """Each DOF joint's armature, kg·m², and where it came from: the scene's ``armature`` (by joint), its
    ``armature_per_effort`` (by kind), the design's per-kind default, the bare-URDF default, or the floor."""
    explicit = match_values(robot.joints, p.armature, "armature")
    unknown = set(p.armature_per_effort) - set(ARMATURE_PER_EFFORT)
    if unknown:
        raise MultibodyModelError(f"armature_per_effort: unknown joint kind(s) {sorted(unknown)}; "
                                  "kinds: bend, twist, screw, other")
    design = _design_table(robot)
    declared = robot.metadata.get("joints") or {}
    out = {}
    for name in robot.joints:
        kind = joint_kind(name, robot.metadata)
        if name in explicit:
            out[name] = (explicit[name], "assembly: armature")
            continue
        if (declared.get(name) or {}).get("armature") is not None:
            out[name] = (float(declared[name]["armature"]), "robot metadata: armature")
            continue
        if kind in p.armature_per_effort:
            per, origin = p.armature_per_effort[kind], "assembly: armature_per_effort"
        elif design is not None:
            per, origin = design[kind], (f"design {robot.design}" if robot.design is not None
                                         else "robot metadata: armature_per_effort")
        else:
            per, origin = ARMATURE_PER_EFFORT[kind], "default for a bare URDF"
        effort = robot.tree.joint_by_name[name].effort
        value = per * effort
        if value < p.armature_floor:
            value, origin = p.armature_floor, f"armature_floor ({origin} gives {value:.3g})"
        else:
            origin = f"{origin}: {per:g} kg·m²/N·m × effort {effort:g} N·m"
        out[name] = (value, origin)
    bad = {k: v for k, (v, _) in out.items() if not (v >= 0 and math.isfinite(v))}
    if bad:
        raise MultibodyModelError(f"armature must be finite and >= 0: {bad}")
    return out


def _design_table(robot) -> dict[str, float] | None:
    """Per-kind armature of the robot: a snakesim design's table, or the metadata's
    ``armature_per_effort`` (a sidecar, a plugin's design) over the bare-URDF defaults."""
    from snakesim.robots.designs import DESIGNS

    if robot.design in DESIGNS:
        return {**ARMATURE_PER_EFFORT, **DESIGNS[robot.design].armature_per_effort}
    if robot.metadata.get("armature_per_effort"):
        return {**ARMATURE_PER_EFFORT, **robot.metadata["armature_per_effort"]}
    return None


def armature_lines(sources: dict[str, tuple[float, str]], kinds: dict[str, str] | None = None) -> list[str]:
    """The armature table of `snakesim check`: one line per (kind, value, source), joints counted."""
    groups: dict[tuple, list[str]] = {}
    for name, (value, origin) in sources.items():
        kind = (kinds or {}).get(name) or joint_kind(name)
        groups.setdefault((kind, round(value, 12), origin), []).append(name)
    lines = ["  armature (reflected rotor inertia, not in the URDF; set armature / armature_per_effort on the "
             "multibody, or 0 for none):"]
    for (kind, value, origin), names in groups.items():
        lines.append(f"    {kind:<6} {len(names):>3} joint(s) {value:10.4g} kg·m²   {origin}")
    return lines


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

    m = dyn.mass_matrix(pin.neutral(dyn.model))
    diag = np.diag(m)
    bad = [robot.v_names[i] for i in range(6, dyn.model.nv) if not diag[i] > 1e-12 * max(1.0, diag.max())]
    if bad:
        raise MultibodyModelError(f"{owner}: joint(s) {', '.join(bad)} move no mass and have no armature; "
                                  "give them armature (params.armature) or mass")
