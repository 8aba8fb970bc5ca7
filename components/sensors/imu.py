"""Inertial measurement unit on a robot link (the ``imu`` frame of the EELS 1.0 head).

At the point p = o + R·offset of link L (o its origin, R its axes in the world)::

    a_p = a_o + α × (R·offset) + ω × (ω × (R·offset))      classical acceleration, world
    angular_rate   = Rᵀ ω + gyro_bias + noise               rad/s, IMU (link) frame
    specific_force = Rᵀ (a_p − g) + accel_bias + noise     m/s², IMU frame (at rest: +|g| up)
    orientation    = the link's quaternion (x, y, z, w), IMU frame -> world

g is params.gravity, scaled by the ``gravity`` input as the multibody's
"scale" mode reads it (connect the same schedule to both; NaN/unconnected:
params.gravity). With a ``rate`` (Hz) the IMU samples and holds, hardware-like;
noise (white, per axis, seeded: see .noise) requires a rate.

in   link_rotations[nl, 3, 3], link_poses[nl, 7], link_velocities[nl, 6],
     link_accelerations[nl, 6]   from the multibody
     gravity[1]                  scale (default: params.gravity)
out  angular_rate[3], specific_force[3], orientation[4]   (feedthrough)
uses robot: RobotModel (the multibody's): the link row
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.components.control.joint_selection import match
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.framework import Component, Input, Output, Params, Uses
from snakesim.components.port_roles import IMU_ANGULAR_RATE, IMU_ORIENTATION, IMU_SPECIFIC_FORCE

from .noise import noise_needs_rate, white_noise

Vec3 = tuple[float, float, float]


class ImuParams(Params):
    link: str = Field("imu", description="link (frame) the IMU is mounted on")
    offset: Vec3 = Field((0.0, 0.0, 0.0), description="m, IMU position in the link frame")
    gravity: Vec3 = Field((0.0, 0.0, -9.81), description="m/s², world (as the multibody's)")
    gyro_noise: float = Field(0.0, ge=0, description="rad/s, standard deviation per axis")
    accel_noise: float = Field(0.0, ge=0, description="m/s², standard deviation per axis")
    gyro_bias: Vec3 = Field((0.0, 0.0, 0.0), description="rad/s")
    accel_bias: Vec3 = Field((0.0, 0.0, 0.0), description="m/s²")
    seed: int = Field(0, ge=0, description="noise seed")


class Imu(Component[ImuParams]):
    type_name = "imu"
    robot = Uses(RobotModel)

    link_rotations = Input(shape=link_shape(3, 3), unit="1")
    link_poses = Input(shape=link_shape(7), unit=None)
    link_velocities = Input(shape=link_shape(6), unit=None)
    link_accelerations = Input(shape=link_shape(6), unit=None)
    gravity = Input(shape=(1,), unit=None, default=np.nan)
    angular_rate = Output(shape=(3,), unit="rad/s", feedthrough=True, names=("x", "y", "z"), role=IMU_ANGULAR_RATE)
    specific_force = Output(shape=(3,), unit="m/s**2", feedthrough=True, names=("x", "y", "z"), role=IMU_SPECIFIC_FORCE)
    orientation = Output(shape=(4,), unit="1", feedthrough=True, names=("qx", "qy", "qz", "qw"), role=IMU_ORIENTATION)

    def setup(self):
        p = self.p
        links = self.robot.links
        if p.link not in links:
            match(links, p.link, f"{self.name}: link")      # raises, listing the links
            raise ValueError(f"{self.name}: link must name one link, not a pattern: '{p.link}'")
        self._i = self.robot.link_index(p.link)
        self._r = np.array(p.offset, dtype=float)
        self._g = np.array(p.gravity, dtype=float)
        self._bias = np.r_[p.gyro_bias, p.accel_bias].astype(float)
        self._std = np.r_[np.full(3, p.gyro_noise), np.full(3, p.accel_noise)]
        self._noisy = bool(self._std.any())
        if not (np.all(np.isfinite(self._r)) and np.all(np.isfinite(self._g)) and np.all(np.isfinite(self._bias))):
            raise ValueError(f"{self.name}: offset, gravity and biases must be finite")
        noise_needs_rate(self.name, self.rate, self._std)

    def discrete_state(self):
        return None if self.rate is None else np.zeros(1)     # sample counter

    def output(self, t, x, u, y):
        i = self._i
        R = u.link_rotations[i]
        w = u.link_velocities[i, 3:]
        r = R @ self._r
        a = u.link_accelerations[i, :3] + np.cross(u.link_accelerations[i, 3:], r) + np.cross(w, np.cross(w, r))
        s = u.gravity[0]
        g = self._g if s != s else s * self._g
        meas = np.r_[R.T @ w, R.T @ (a - g)] + self._bias
        if self._noisy:
            meas += white_noise(self.p.seed, x[0], self._std)
        y.angular_rate[:] = meas[:3]
        y.specific_force[:] = meas[3:]
        y.orientation[:] = u.link_poses[i, 3:7]

    def update(self, t, xd, u):
        xd[0] += 1.0
