"""Initial shape guesses (paper 2.2.6): target curves for the robot's backbone.

Every curve is given in a SHAPE FRAME and sampled by arc length s (m) from the
tail; :class:`Pose` then places the shape frame in the world. In the shape
frame (x ahead, z up)::

    straight             c(s) = (s, 0, 0)
    crescent(R)          c(s) = (R sin(s/R), R (1 − cos(s/R)), 0)
                         an arc of radius |R| in the x-y plane, curving to +y (R > 0) or −y (R < 0)
    helix(r, pitch, φ0)  c(θ) = (pitch θ/2π, r cos(θ+φ0), r sin(θ+φ0)),  ds = sqrt(r² + (pitch/2π)²) dθ
                         axis = the shape frame's x axis; the tail starts at angle φ0 about it;
                         pitch > 0 right-handed, < 0 left-handed
    s_curve(A, λ, φ0)    c(x) = (x, A sin(2π x/λ + φ0), 0), re-sampled by arc length
    joints               no curve: the user's joint vector is the shape (q0 as given)

Shape kinds that place the robot themselves (a brace surveyed and fitted in a shaft: shaft_brace.py) are
Params classes with a ``kind`` literal and ``place(robot, limits) -> Placement``, registered with
:func:`register_placer`; placed_multibody validates its ``shape`` by kind against them (:func:`shape_of`),
and every shape is placed by its own ``place``.

The curve is the path of the backbone (the joint axes' intersection points
along the chain); the fit (fit.py) puts the robot's bend points on it.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from snakesim.components.multibody.pose_quaternions import rotation_matrices
from snakesim.framework import Params

Vec3 = tuple[float, float, float]
KINDS = ("straight", "crescent", "helix", "s_curve", "joints")


class Pose(Params):
    """Where the shape frame sits in the world: position, then yaw (z), pitch (y), roll (x), or a quaternion."""

    position: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = Field((0.0, 0.0, 0.0), description="rad, roll-pitch-yaw (R = Rz(yaw) Ry(pitch) Rx(roll))")
    quaternion: tuple[float, float, float, float] | None = Field(None, description="(x, y, z, w); replaces rpy")

    def rotation(self) -> np.ndarray:
        if self.quaternion is not None:
            return rotation_matrices(np.asarray(self.quaternion, float) / np.linalg.norm(self.quaternion))
        r, p, y = self.rpy
        cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
        rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
        ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
        rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
        return rz @ ry @ rx


class Shape(Params):
    """A shape guess: ``kind`` and the fields that kind reads (others must stay unset)."""

    kind: Literal["straight", "crescent", "helix", "s_curve", "joints"] = "straight"
    radius: float | None = Field(None, description="m: crescent arc radius (signed) or helix radius (> 0)")
    pitch: float | None = Field(None, description="m per turn of the helix (signed: hand)")
    amplitude: float | None = Field(None, description="m, s-curve lateral amplitude")
    wavelength: float | None = Field(None, gt=0, description="m, s-curve wavelength along x")
    phase: float = Field(0.0, description="rad: helix start angle φ0 / s-curve phase φ0")
    q: dict[str, float] | list[float] | None = Field(None, description="joints kind: joint angles by name/pattern or vector")
    pose: Pose = Field(default_factory=Pose)

    def place(self, robot, limits: dict | None = None):
        """Initial joint angles and tail pose: the fit of fit.py."""
        from .fit import fit_shape

        return fit_shape(robot, self, limits)

    @model_validator(mode="after")
    def _check(self):
        need = {"straight": (), "crescent": ("radius",), "helix": ("radius", "pitch"),
                "s_curve": ("amplitude", "wavelength"), "joints": ("q",)}[self.kind]
        missing = [k for k in need if getattr(self, k) is None]
        if missing:
            raise ValueError(f"shape kind '{self.kind}' needs {', '.join(missing)} "
                             f"(it reads: {', '.join(need) or 'nothing but pose'})")
        unused = [k for k in ("radius", "pitch", "amplitude", "wavelength", "q")
                  if k not in need and getattr(self, k) is not None]
        if unused:
            raise ValueError(f"shape kind '{self.kind}' does not read {', '.join(unused)} "
                             f"(it reads: {', '.join(need) or 'nothing but pose'})")
        if self.kind == "crescent" and self.radius == 0:
            raise ValueError("crescent radius must be non-zero (sign: curve to +y or −y)")
        if self.kind == "helix" and (self.radius <= 0 or self.pitch == 0):
            raise ValueError(f"helix needs radius > 0 and pitch ≠ 0, got radius={self.radius}, pitch={self.pitch}")
        return self


def local_curve(shape: Shape, length: float, n: int = 4001) -> np.ndarray:
    """(n, 3) points of the curve in the shape frame, evenly spaced in arc length over [0, length] m."""
    s = np.linspace(0.0, length, n)
    k = shape.kind
    if k == "straight":
        return np.stack([s, 0 * s, 0 * s], axis=1)
    if k == "crescent":
        R = shape.radius
        return np.stack([R * np.sin(s / R), R * (1 - np.cos(s / R)), 0 * s], axis=1)
    if k == "helix":
        r, c = shape.radius, shape.pitch / (2 * math.pi)
        th = s / math.hypot(r, c)
        return np.stack([c * th * np.sign(c), r * np.cos(th * np.sign(c) + shape.phase),
                         r * np.sin(th * np.sign(c) + shape.phase)], axis=1)
    if k == "s_curve":
        A, w = shape.amplitude, 2 * math.pi / shape.wavelength
        x = np.linspace(0.0, length, 8 * n)           # arc length ≥ x: resample the dense curve
        y = A * np.sin(w * x + shape.phase)
        seg = np.hypot(np.diff(x), np.diff(y))
        arc = np.concatenate([[0.0], np.cumsum(seg)])
        xs = np.interp(s, arc, x)
        return np.stack([xs, A * np.sin(w * xs + shape.phase), 0 * s], axis=1)
    raise ValueError(f"shape kind '{k}' has no curve")


def world_curve(shape: Shape, length: float, n: int = 4001) -> np.ndarray:
    """The curve in the world: pose.position + R(pose) · local point, (n, 3)."""
    R = shape.pose.rotation()
    return local_curve(shape, length, n) @ R.T + np.asarray(shape.pose.position, float)


#: shape kinds that place themselves: kind -> Params class with ``place(robot, limits) -> Placement``
PLACERS: dict[str, type[Params]] = {}


def register_placer(cls: type[Params]) -> type[Params]:
    """Register a self-placing shape kind (its ``kind`` field's default names it)."""
    kind = cls.model_fields["kind"].default
    known = PLACERS.get(kind)
    if kind in KINDS or (known is not None and (known.__module__, known.__qualname__) != (cls.__module__,
                                                                                         cls.__qualname__)):
        raise ValueError(f"shape kind '{kind}' is already registered")
    PLACERS[kind] = cls
    return cls


def shape_of(value):
    """A ``shape:`` mapping as its kind's Params: a registered placer's, else :class:`Shape` (which names the
    kinds it knows; the error adds the placers')."""
    if isinstance(value, dict) and value.get("kind") in PLACERS:
        return PLACERS[value["kind"]].model_validate(value)
    if isinstance(value, dict):
        if value.get("kind", "straight") not in KINDS:
            raise ValueError(f"shape kind '{value.get('kind')}' is unknown: valid kinds are "
                             f"{', '.join(KINDS + tuple(PLACERS))}")
        return Shape.model_validate(value)
    return value
