"""6-axis force-torque sensors between modules (paper 2.2.4), e.g. EELS 1.5's fts_joint_NN.

Each sensor is a cut of the multibody: a fixed joint whose child link (fts_NN)
is the sensor body, positioned at the transducer's sensing frame. The
multibody's ``joint_wrenches`` give, for every link, the wrench its parent
side (toward the tail) exerts on it across its parent joint, in the link's
frame about its origin; this component picks the rows of the sensor links and
reads them as the sensor does, as a geometry_msgs/WrenchStamped would carry it
(force then torque, frame_id = the sensor link)::

    wrench_k = s · joint_wrenches[child link of cut k] + bias_k + noise_k
    s = +1 ("parent_on_child", default) or −1 ("child_on_parent")
    noise_k ~ N(0, diag(force_noise² I₃, torque_noise² I₃)), seeded (see .noise)

Hanging from the head, a sensor reads (+) the weight of the part below it
(the tail side pulls down on the child side); standing on the tail it reads
minus the weight of the part above it.

``cuts`` (joint or link names, or glob patterns of either; default
``fts_joint_*``) are resolved on the robot here alone: the multibody outputs
every link's joint wrench, so nothing is repeated on it (the old requirement
that ``fts_cuts`` be given to the multibody too, same patterns in the same
order, is gone). Sensors are ordered as the patterns name them; ``bias`` keys
are sensor (cut joint) names or patterns. With a ``rate`` the readings are
sampled and held; noise requires a rate.

in   joint_wrenches[nl, 6]  from multibody.joint_wrenches
out  wrench[nc, 6]          N, N·m, sensor frame   (feedthrough)
uses robot: RobotModel (the multibody's): the cuts and their links' rows
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.components.control.joint_selection import per_joint
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.framework import Component, Input, Output, Params, Uses
from snakesim.components.port_roles import JOINT_WRENCHES, SENSOR_WRENCHES

from .noise import noise_needs_rate, white_noise

AXES = ("fx", "fy", "fz", "tx", "ty", "tz")


class FtsParams(Params):
    cuts: list[str] = Field(default_factory=lambda: ["fts_joint_*"],
                            description="sensor cuts: joint or link names, or glob patterns of either")
    convention: Literal["parent_on_child", "child_on_parent"] = "parent_on_child"
    force_noise: float = Field(0.0, ge=0, description="N, standard deviation per axis")
    torque_noise: float = Field(0.0, ge=0, description="N·m, standard deviation per axis")
    bias: dict[str, list[float]] = Field(default_factory=dict,
                                         description="[fx, fy, fz, tx, ty, tz] by sensor (cut) name/pattern")
    seed: int = Field(0, ge=0, description="noise seed")


class ForceTorqueSensors(Component[FtsParams]):
    type_name = "force_torque_sensors"
    robot = Uses(RobotModel)

    joint_wrenches = Input(shape=link_shape(6), unit=None, role=JOINT_WRENCHES)
    wrench = Output(shape=lambda c: (len(c.sensor_names), 6), unit=None, feedthrough=True,
                    names=lambda c: tuple(f"{s}.{a}" for s in c.sensor_names for a in AXES), role=SENSOR_WRENCHES)

    def setup(self):
        p, robot = self.p, self.robot
        try:
            names, links = robot.cuts(p.cuts)
        except ValueError as e:
            raise ValueError(f"{self.name}: cuts: {e}") from None
        self.sensor_names = list(names)
        self._rows = np.array([robot.link_index(ln) for ln in links], dtype=np.intp)   # rows of joint_wrenches
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
        w = y.wrench
        # the sensor links' rows; mode "clip" (the rows are valid) writes straight into w, unbuffered
        np.take(u.joint_wrenches, self._rows, axis=0, out=w, mode="clip")
        w *= self._sign
        w += self._bias
        if self._noisy:
            w += white_noise(self.p.seed, x[0], self._std)

    def update(self, t, xd, u):
        xd[0] += 1.0
