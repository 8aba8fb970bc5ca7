"""Gait sources: set-point vectors for :mod:`.pid`, matched to the robot's DOF joints.

Each source outputs ``setpoint[nj]`` (rad for position-mode joints, rad/s for
velocity-mode ones, as the PID reads them) and ``rate[nj]`` (rad/s, the
set-point's time derivative, for the PID's ``rate_ref``), joints in the
multibody's order (``robot.joints``).

uses robot: RobotModel (the multibody's): joint names and kinds (screw or not)

joint_setpoints: constant screw speeds and locked bend/twist joints (paper 4.2):
    screws:      screw_speed · screw_direction[j]      (direction ±1 by name/pattern, default +1)
    other joints: hold[j] (rad, default 0: straight; pass the multibody's q0 to hold the initial shape)
    setpoints:   explicit values by name/pattern, applied last
serpenoid_gait: a travelling sine wave over ``wave_joints`` (index i along the body, tail first):
    θ_i(t) = offset + amplitude · sin(2π f t − 2π i / wavelength + phase)
    "undulation" is that wave; "sidewinding" adds a second wave on ``second_joints``
    shifted by ``second_phase`` (π/2 classically). Other joints as joint_setpoints.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Component, Output, Params, Uses

from .joint_selection import finite_or_raise, match, per_joint


class JointSetpointsParams(Params):
    screw_speed: float = Field(0.0, description="rad/s, every screw joint")
    screw_direction: dict[str, float] = Field(default_factory=dict,
                                              description="multiplier (e.g. -1) by screw joint name/pattern")
    hold: dict[str, float] = Field(default_factory=dict, description="rad, held angle of non-screw joints")
    setpoints: dict[str, float] = Field(default_factory=dict, description="explicit value by joint name/pattern")


def _nj(c):
    return (c.robot.nj,)


def _joints(c):
    return c.robot.joints


def constant_setpoints(robot: RobotModel, p, owner: str) -> np.ndarray:
    """The joint_setpoints vector of params ``p`` for ``robot`` (also the base the wave gaits start from)."""
    names = robot.joints
    for what in ("screw_direction", "hold", "setpoints"):
        finite_or_raise(getattr(p, what), f"{owner}: {what}")
    if not math.isfinite(p.screw_speed):
        raise ValueError(f"{owner}: screw_speed must be finite, got {p.screw_speed}")
    screw = np.array([k == "screw" for k in robot.joint_kinds], dtype=bool)
    direction = np.array(per_joint(names, p.screw_direction, f"{owner}: screw_direction", 1.0), dtype=float)
    not_screws = [names[i] for i in np.flatnonzero(~screw) if direction[i] != 1.0]
    if not_screws and p.screw_direction:
        raise ValueError(f"{owner}: screw_direction names non-screw joints {not_screws}")
    hold = np.array(per_joint(names, p.hold, f"{owner}: hold", 0.0), dtype=float)
    out = np.where(screw, p.screw_speed * direction, hold)
    explicit = per_joint(names, p.setpoints, f"{owner}: setpoints", None)
    return np.array([o if e is None else float(e) for o, e in zip(out, explicit)], dtype=float)


class JointSetpoints(Component[JointSetpointsParams]):
    type_name = "joint_setpoints"
    Params = JointSetpointsParams
    robot = Uses(RobotModel)
    setpoint = Output(shape=_nj, unit=None, feedthrough=(), names=_joints)
    rate = Output(shape=_nj, unit="rad/s", feedthrough=(), names=_joints)

    def setup(self):
        self._value = constant_setpoints(self.robot, self.p, self.name)

    def output(self, t, x, u, y):
        y.setpoint[:] = self._value
        y.rate[:] = 0.0


class SerpenoidParams(JointSetpointsParams):
    kind: Literal["undulation", "sidewinding"] = "undulation"
    wave_joints: str = Field("bend_*", description="name pattern of the joints carrying the wave")
    amplitude: float = Field(0.3, description="rad")
    frequency: float = Field(0.2, ge=0, description="Hz")
    wavelength: float = Field(4.0, gt=0, description="spatial period, in joints along the wave")
    phase: float = Field(0.0, description="rad")
    offset: float = Field(0.0, description="rad")
    second_joints: str = Field("twist_*", description="sidewinding: pattern of the second wave's joints")
    second_amplitude: float = Field(0.2, description="rad")
    second_phase: float = Field(math.pi / 2, description="rad, shift of the second wave")


class SerpenoidGait(Component[SerpenoidParams]):
    type_name = "serpenoid_gait"
    Params = SerpenoidParams
    robot = Uses(RobotModel)
    setpoint = Output(shape=_nj, unit=None, feedthrough=(), names=_joints)
    rate = Output(shape=_nj, unit="rad/s", feedthrough=(), names=_joints)

    def setup(self):
        p, names = self.p, self.robot.joints
        self._base = constant_setpoints(self.robot, p, self.name)
        idx = [np.array(match(names, p.wave_joints, f"{self.name}: wave_joints"))]
        amp, ph = [p.amplitude], [p.phase]
        if p.kind == "sidewinding":
            idx.append(np.array(match(names, p.second_joints, f"{self.name}: second_joints")))
            amp.append(p.second_amplitude)
            ph.append(p.phase + p.second_phase)
        self._idx = np.concatenate(idx)
        # spatial phase per wave joint: its position along its own wave
        self._k = np.concatenate([-2.0 * np.pi * np.arange(i.size) / p.wavelength + f for i, f in zip(idx, ph)])
        self._amp = np.concatenate([np.full(i.size, a) for i, a in zip(idx, amp)])
        self._w = 2.0 * np.pi * p.frequency

    def output(self, t, x, u, y):
        arg = self._w * t + self._k
        y.setpoint[:] = self._base
        y.setpoint[self._idx] = self.p.offset + self._amp * np.sin(arg)
        y.rate[:] = 0.0
        y.rate[self._idx] = self._amp * self._w * np.cos(arg)
