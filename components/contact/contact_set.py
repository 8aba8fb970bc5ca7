"""ContactSet: the structured signal a contact model emits for viewers and loggers.

One evaluation's active contacts (penetrating samples only), world frame, SI units:

    points[m,3]        m     where each force acts (the sample on the robot)
    normals[m,3]       1     outward terrain normal
    forces[m,3]        N     force on the robot (normal + friction)
    normal_force[m]    N     F_n (eq. 2)
    depth[m]           m     penetration (> 0)
    slip[m,3]          m/s   velocity of the robot's material point (spin included)
    link[m]            int   row (in the multibody's link order) of the link it acts on
    material[m]        int   terrain material index
    link_names               names of the rows ``link`` indexes

Arrays are fresh copies (safe to keep). Shared by every contact back end.
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class ContactSet:
    t: float
    points: np.ndarray
    normals: np.ndarray
    forces: np.ndarray
    normal_force: np.ndarray
    depth: np.ndarray
    slip: np.ndarray
    link: np.ndarray
    material: np.ndarray
    link_names: tuple[str, ...] = ()

    def __len__(self) -> int:
        return int(self.normal_force.shape[0])

    @property
    def total_force(self) -> np.ndarray:
        """Σ forces (3,), N."""
        return self.forces.sum(axis=0)

    @classmethod
    def empty(cls, link_names=(), t: float = 0.0) -> "ContactSet":
        z3, z = np.zeros((0, 3)), np.zeros(0)
        zi = np.zeros(0, dtype=np.int64)
        return cls(t, z3, z3, z3, z, z, z3, zi, zi, tuple(link_names))
