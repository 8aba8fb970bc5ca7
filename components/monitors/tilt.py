"""The mobility failure rule (paper 4.3.1) that the mobility monitor and the vertical-mobility
evaluation both apply: the angle of each watched link's body axis from the vertical::

    â_j = R_j·axis/|axis|,  û = −g/|g|
    vertical "up":   θ_j = arccos(â_j · û)      "down": arccos(−â_j · û)      "line": arccos(|â_j · û|)

and a failure when max_j θ_j > max_tilt. The monitor takes R_j from link_rotations, the evaluation
from the poses' quaternions; the rule is the same.
"""

from __future__ import annotations

import math

import numpy as np

from snakesim.components.control.joint_selection import match


def tilt_from_vertical(axes: np.ndarray, up: np.ndarray, vertical: str) -> np.ndarray:
    """The angles (rad) of unit body axes ``axes`` (n, 3) from the vertical ``up``, as ``vertical`` reads it."""
    c = axes @ up
    if vertical == "down":
        c = -c
    elif vertical == "line":
        c = np.abs(c)
    return np.arccos(np.clip(c, -1.0, 1.0))


class TiltRule:
    """The rule's set-up from a monitor's params (``gravity``, ``axis``, ``tilt_links``, ``vertical``,
    ``max_tilt``): ``up`` û, ``axis`` the unit body axis (link frame), ``rows`` the watched links' rows
    (link order) and ``names`` theirs. ``owner`` names the monitor in errors."""

    def __init__(self, owner: str, links, p):
        links = list(links)
        g, a = np.array(p.gravity, dtype=float), np.array(p.axis, dtype=float)
        if not (np.linalg.norm(g) > 0 and np.linalg.norm(a) > 0):
            raise ValueError(f"{owner}: gravity and axis need a direction (non-zero), got {p.gravity}, {p.axis}")
        self.up, self.axis = -g / np.linalg.norm(g), a / np.linalg.norm(a)
        rows = sorted({i for pat in p.tilt_links for i in match(links, pat, f"{owner}: tilt_links")})
        self.rows = np.array(rows, dtype=np.int64)
        self.names = tuple(links[i] for i in rows)
        self.vertical, self.max_tilt = p.vertical, p.max_tilt

    def angles(self, axes: np.ndarray) -> np.ndarray:
        """θ (rad) of the watched links' body axes ``axes`` (n, 3, world)."""
        return tilt_from_vertical(axes, self.up, self.vertical)

    def failure(self, tilt: np.ndarray, worst: float) -> str:
        """The stop reason for a failure whose largest angle ``worst`` (rad) is ``tilt``'s."""
        j = int(np.argmax(tilt))
        return (f"mobility failure: {self.names[j]} tilted {math.degrees(worst):.1f} deg from the "
                f"vertical ({self.vertical}), limit {math.degrees(self.max_tilt):.1f} deg")
