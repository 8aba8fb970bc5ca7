"""The two ROS-expressible central models: pinhole and equidistant fisheye.

Pinhole (ROS "plumb_bob" with zero distortion), for z > 0::

    u = fx·x/z + cx,   v = fy·y/z + cy

Equidistant fisheye (ROS "equidistant" with D = 0, i.e. OpenCV's fisheye model
without distortion): the image radius is proportional to the angle θ from the
axis, so the field of view may exceed 180°::

    θ = atan2(√(x² + y²), z),   (u, v) = (cx, cy) + f·θ·(x, y)/√(x² + y²)

Both have their centre at the sensor origin, which is every ray's origin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .base import CameraModel, as_pixels, as_points, check_finite, degrees_in, pinhole_camera_info, unit


@dataclass(frozen=True)
class PinholeModel(CameraModel):
    """Perspective camera: focal lengths fx, fy and principal point cx, cy, in pixels."""

    fx: float
    fy: float
    cx: float
    cy: float

    def __post_init__(self):
        super().__post_init__()
        check_finite(fx=self.fx, fy=self.fy, cx=self.cx, cy=self.cy)
        for key in ("fx", "fy"):
            if not getattr(self, key) > 0:
                raise ValueError(f"{key} = {getattr(self, key)!r}: must be > 0 (pixels per unit of x/z)")

    @classmethod
    def from_fov(cls, width: int, height: int, fov: float) -> PinholeModel:
        """Square pixels, principal point at the image centre, ``fov`` degrees edge to edge across the width."""
        half = degrees_in("fov", fov, 0, 180, False, "; use kind: fisheye for 180° or more") / 2
        f = (width / 2) / math.tan(half)
        return cls(width, height, f, f, (width - 1) / 2, (height - 1) / 2)

    def project(self, points):
        p = as_points(points)
        x, y, z = p.T
        valid = z > 0
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack([self.fx * x / z + self.cx, self.fy * y / z + self.cy], axis=1)
        uv[~valid] = np.nan
        return uv, valid

    def unproject(self, uv):
        q = as_pixels(uv)
        directions = np.stack(
            [(q[:, 0] - self.cx) / self.fx, (q[:, 1] - self.cy) / self.fy, np.ones(len(q))], axis=1
        )
        return np.zeros_like(directions), unit(directions)

    def camera_info(self):
        return pinhole_camera_info("plumb_bob", [0.0] * 5, self.fx, self.fy, self.cx, self.cy)


@dataclass(frozen=True)
class FisheyeModel(CameraModel):
    """Equidistant fisheye: r = f·θ, f in pixels per radian, image centre cx, cy in pixels."""

    f: float
    cx: float
    cy: float

    def __post_init__(self):
        super().__post_init__()
        check_finite(f=self.f, cx=self.cx, cy=self.cy)
        if not self.f > 0:
            raise ValueError(f"f = {self.f!r}: must be > 0 (pixels per radian)")

    @classmethod
    def from_fov(cls, width: int, height: int, fov: float) -> FisheyeModel:
        """Centred, ``fov`` degrees edge to edge across the width (up to 360: θ = π at the edges)."""
        half = degrees_in("fov", fov, 0, 360, True) / 2
        return cls(width, height, (width / 2) / half, (width - 1) / 2, (height - 1) / 2)

    def project(self, points):
        p = as_points(points)
        x, y, z = p.T
        radial = np.hypot(x, y)
        theta = np.arctan2(radial, z)
        # θ = π (straight behind) has no image direction; the sensor origin has no angle at all.
        valid = (theta < np.pi) & ((radial > 0) | (z > 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(radial > 0, self.f * theta / radial, 0.0)
        uv = np.stack([self.cx + scale * x, self.cy + scale * y], axis=1)
        uv[~valid] = np.nan
        return uv, valid

    def unproject(self, uv):
        q = as_pixels(uv)
        du, dv = (q[:, 0] - self.cx) / self.f, (q[:, 1] - self.cy) / self.f
        theta = np.hypot(du, dv)
        sinc = np.where(theta > 0, np.sin(theta) / np.where(theta > 0, theta, 1.0), 1.0)
        directions = unit(np.stack([du * sinc, dv * sinc, np.cos(theta)], axis=1))
        directions[theta > np.pi] = np.nan  # past the antipode the radius no longer names one direction
        return np.zeros_like(directions), directions

    def camera_info(self):
        return pinhole_camera_info("equidistant", [0.0] * 4, self.f, self.f, self.cx, self.cy)
