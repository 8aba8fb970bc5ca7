"""Rigid-body mass properties of the simple solids EELS bodies are modelled as.

Every body of a generated robot is a solid cylinder, a thick-walled tube
(the screws: a drum whose mass sits away from the axis) or a solid box. Using
closed-form inertias of real solids guarantees the tensors are physically
valid: positive definite and satisfying the triangle inequalities
``I_a + I_b >= I_c`` for every permutation of the principal moments.

Units: kg, m, kg·m². Tensors are about the body's centre of mass, expressed in
axes whose x axis is the solid's symmetry axis (the robot axis for every
EELS body), y and z transverse.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class MassProperties:
    """Mass (kg), centre of mass (m, in the link frame) and the diagonal of the
    inertia tensor about the centre of mass (kg·m², link-frame axes)."""

    mass: float
    com: tuple[float, float, float]
    inertia_diagonal: tuple[float, float, float]

    def tensor(self) -> np.ndarray:
        """The 3x3 inertia tensor about the centre of mass (kg·m²)."""
        return np.diag(self.inertia_diagonal)


def solid_cylinder_x(mass: float, radius: float, length: float) -> tuple[float, float, float]:
    """Principal inertias (Ixx, Iyy, Izz) of a solid cylinder whose axis is x.

    Ixx = m r² / 2 (about the axis); Iyy = Izz = m (3 r² + L²) / 12.
    """
    _require_positive(mass=mass, radius=radius, length=length)
    axial = 0.5 * mass * radius**2
    transverse = mass * (3.0 * radius**2 + length**2) / 12.0
    return (axial, transverse, transverse)


def tube_x(mass: float, inner_radius: float, outer_radius: float, length: float) -> tuple[float, float, float]:
    """Principal inertias of a thick-walled tube (hollow cylinder) with axis x.

    Ixx = m (r_i² + r_o²) / 2; Iyy = Izz = m (3 (r_i² + r_o²) + L²) / 12.
    Used for screws: their mass (blades and drum skin) lies near the outer
    radius, so a solid cylinder would underestimate the spin inertia the
    screw motors see.
    """
    _require_positive(mass=mass, outer_radius=outer_radius, length=length)
    if not 0.0 <= inner_radius < outer_radius:
        raise ValueError(f"tube inner radius {inner_radius} m must be in [0, outer radius {outer_radius} m)")
    r2 = inner_radius**2 + outer_radius**2
    return (0.5 * mass * r2, mass * (3.0 * r2 + length**2) / 12.0, mass * (3.0 * r2 + length**2) / 12.0)


def solid_box(mass: float, size_x: float, size_y: float, size_z: float) -> tuple[float, float, float]:
    """Principal inertias of a solid box with edge lengths along x, y, z.

    Ixx = m (y² + z²) / 12 and cyclic permutations.
    """
    _require_positive(mass=mass, size_x=size_x, size_y=size_y, size_z=size_z)
    return (
        mass * (size_y**2 + size_z**2) / 12.0,
        mass * (size_x**2 + size_z**2) / 12.0,
        mass * (size_x**2 + size_y**2) / 12.0,
    )


def is_physical(mass: float, inertia: np.ndarray, rtol: float = 1e-9) -> bool:
    """True when (mass, inertia about the COM) can belong to a real rigid body.

    Conditions: mass > 0, the tensor is symmetric, its principal moments are
    positive and every one is at most the sum of the other two (the triangle
    inequality, which holds because I_a + I_b - I_c = 2 ∫ c² dm >= 0).
    """
    inertia = np.asarray(inertia, dtype=float)
    if not mass > 0.0 or inertia.shape != (3, 3):
        return False
    if not np.allclose(inertia, inertia.T, rtol=rtol, atol=0.0):
        return False
    moments = np.linalg.eigvalsh(inertia)
    if np.any(moments <= 0.0):
        return False
    slack = rtol * moments.sum()
    return bool(all(moments[i] <= moments[(i + 1) % 3] + moments[(i + 2) % 3] + slack for i in range(3)))


def _require_positive(**values: float) -> None:
    for name, value in values.items():
        if not value > 0.0:
            raise ValueError(f"{name} must be > 0, got {value}")
