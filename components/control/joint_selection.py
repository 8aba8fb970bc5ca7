"""Per-joint (or per-link, per-sensor) values by name or glob pattern.

``{"screw_*": 2.0, "bend_03": 0.1}``: exact names first, then patterns in the
order given; a key that matches nothing is an error listing the valid names.
The names themselves come from the robot (``self.robot.joints``,
``self.robot.links``: :class:`~snakesim.components.multibody.RobotModel`).
"""

from __future__ import annotations

import fnmatch
import math
from typing import Any

import numpy as np


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
