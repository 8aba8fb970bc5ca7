"""The robot a controller, sensor or monitor serves: the same source keys the multibody takes.

Every robot-facing component here (PID, gaits, FTS, IMU, tethers, monitors)
subclasses :class:`RobotSource`, so an assembly passes the robot once as
parameters and repeats them::

    parameters: {design: eels-1.5, modules: 4}
    components:
      robot: {type: multibody, params: {design: "${design}", modules: "${modules}"}}
      pid:   {type: joint_pid, params: {design: "${design}", modules: "${modules}"}, rate: 1000}

Names and their order come from :func:`robot_layout`, which is the
multibody's own cached URDF parse (``components.multibody.layout.layout_of``):
the joint order of ``tau[nj]``/``joint_q[nj]`` and the link order of
``link_poses[nl, 7]``/``wrenches[nl, 6]`` are therefore identical by
construction, never re-derived. A bare ``urdf`` (text or path) works the same.

Per-joint values by name or glob pattern (``{"screw_*": 2.0}``) go through
:func:`per_joint`: exact names first, then patterns in the order given; a
key that matches nothing is an error listing the joints.
"""

from __future__ import annotations

import fnmatch
import math
from types import SimpleNamespace
from typing import Any

import numpy as np

from snakesim.components.multibody.robot_source import RobotSource  # noqa: F401  (re-exported)

JOINT_KINDS = ("bend", "twist", "screw", "other")


def robot_layout(p, fts_cuts: list[str] | tuple[str, ...] = ()):
    """The multibody's Layout for the robot named by ``p``: ``.joints``, ``.links``, ``.cuts``, ``.tree``."""
    from snakesim.components.multibody.layout import layout_of

    src = SimpleNamespace(urdf=p.urdf, design=p.design, modules=p.modules, head=p.head, robot=dict(p.robot),
                          fts_cuts=list(fts_cuts))
    return layout_of(src)


def joint_names(p) -> tuple[str, ...]:
    return tuple(robot_layout(p).joints)


def link_names(p) -> tuple[str, ...]:
    return tuple(robot_layout(p).links)


def joint_kind(name: str) -> str:
    """bend | twist | screw | other, from the systematic names of snakesim.robots."""
    from snakesim.components.multibody.model import joint_kind as _kind

    return _kind(name)


def continuous_mask(p) -> np.ndarray:
    """True for continuous (unbounded, wrapped) joints among the DOF joints."""
    lay = robot_layout(p)
    return np.array([lay.tree.joint_by_name[j].type == "continuous" for j in lay.joints], dtype=bool)


def effort_limits(p) -> np.ndarray:
    """URDF <limit effort> per DOF joint, N·m; +inf where the URDF gives none."""
    lay = robot_layout(p)
    e = np.array([lay.tree.joint_by_name[j].effort for j in lay.joints], dtype=float)
    return np.where(e > 0, e, np.inf)


def match(names, key: str, what: str) -> list[int]:
    """Indices of ``names`` equal to ``key`` or matching it as a glob; an error if none."""
    names = list(names)
    if key in names:
        return [names.index(key)]
    hits = [i for i, n in enumerate(names) if fnmatch.fnmatchcase(n, key)]
    if not hits:
        raise ValueError(f"{what}: '{key}' matches no name; valid: {', '.join(names)}")
    return hits


def per_joint(names, values: dict[str, Any], what: str, default=None) -> list:
    """One value per name: exact keys first, then the first matching pattern in the order given."""
    names = list(names)
    for key in values:
        match(names, key, what)
    out = []
    for n in names:
        if n in values:
            out.append(values[n])
            continue
        out.append(next((v for k, v in values.items() if fnmatch.fnmatchcase(n, k)), default))
    return out


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angles to (-π, π]."""
    return np.pi - np.mod(np.pi - a, 2.0 * np.pi)


def finite_or_raise(values: dict[str, float], what: str) -> None:
    bad = {k: v for k, v in values.items() if not (isinstance(v, (int, float)) and math.isfinite(v))}
    if bad:
        raise ValueError(f"{what}: values must be finite numbers, got {bad}")
