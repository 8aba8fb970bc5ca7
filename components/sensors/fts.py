"""6-axis force-torque sensors between modules (paper 2.2.4), e.g. EELS 1.5's fts_joint_NN.

Each sensor is a cut of the multibody: a fixed joint whose child link (fts_NN)
is the sensor body, positioned at the transducer's sensing frame. The
multibody's ``cut_wrenches`` give the wrench the parent side (toward the
tail) exerts on the child side, in the child link's frame about its origin;
this component reads it as the sensor does, as a geometry_msgs/WrenchStamped
would carry it (force then torque, frame_id = the sensor link)::

    wrench_k = s · cut_wrench_k + bias_k + noise_k
    s = +1 ("parent_on_child", default) or −1 ("child_on_parent")
    noise_k ~ N(0, diag(force_noise² I₃, torque_noise² I₃)), seeded (see .noise)

Hanging from the head, a sensor reads (+) the weight of the part below it
(the tail side pulls down on the child side); standing on the tail it reads
minus the weight of the part above it.

``fts_cuts`` must be the multibody's (same patterns, same order: the
shapes are checked at build). With a ``rate`` the readings are sampled and
held; noise requires a rate.

in   cut_wrenches[nc, 6]  from multibody.cut_wrenches
out  wrench[nc, 6]        N, N·m, sensor frame   (feedthrough)
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.components.control.robot_source import RobotSource, per_joint, robot_layout

from snakesim.framework import Component, Input, Output

from .noise import noise_needs_rate, white_noise


class FtsParams(RobotSource):
    fts_cuts: list[str] = Field(default_factory=lambda: ["fts_joint_*"],
                                description="the multibody's fts_cuts: joint or link names/patterns")
    convention: Literal["parent_on_child", "child_on_parent"] = "parent_on_child"
    force_noise: float = Field(0.0, ge=0, description="N, standard deviation per axis")
    torque_noise: float = Field(0.0, ge=0, description="N·m, standard deviation per axis")
    bias: dict[str, list[float]] = Field(default_factory=dict,
                                         description="[fx, fy, fz, tx, ty, tz] by sensor (cut) name/pattern")
    seed: int = Field(0, ge=0, description="noise seed")


def _cuts(p):
    return robot_layout(p, p.fts_cuts).cuts


def _shape(p):
    return (len(_cuts(p)), 6)


def _names(p):
    return tuple(f"{c}.{s}" for c in _cuts(p) for s in ("fx", "fy", "fz", "tx", "ty", "tz"))


class ForceTorqueSensors(Component[FtsParams]):
    type_name = "force_torque_sensors"
    Params = FtsParams

    cut_wrenches = Input(shape=_shape, unit=None)
    wrench = Output(shape=_shape, unit=None, feedthrough=True, names=_names)

    def setup(self):
        p = self.p
        self.sensor_names = list(_cuts(p))
        nc = len(self.sensor_names)
        self._sign = 1.0 if p.convention == "parent_on_child" else -1.0
        bias = per_joint(self.sensor_names, p.bias, f"{self.name}: bias", [0.0] * 6)
        bad = [b for b in bias if len(b) != 6 or not np.all(np.isfinite(b))]
        if bad:
            raise ValueError(f"{self.name}: bias needs 6 finite values [fx, fy, fz, tx, ty, tz], got {bad[0]}")
        self._bias = np.array(bias, dtype=float).reshape(nc, 6)
        self._std = np.tile(np.r_[np.full(3, p.force_noise), np.full(3, p.torque_noise)], (nc, 1))
        self._noisy = bool(self._std.any())
        noise_needs_rate(self.name, self.rate, self._std)

    def discrete_state(self):
        return None if self.rate is None else np.zeros(1)     # sample counter

    def output(self, t, x, u, y):
        np.multiply(u.cut_wrenches, self._sign, out=y.wrench)
        y.wrench += self._bias
        if self._noisy:
            y.wrench += white_noise(self.p.seed, x[0], self._std)

    def update(self, t, xd, u):
        xd[0] += 1.0
