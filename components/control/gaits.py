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
    θ_i(t) = offset + amplitude · sin(ψ(t) − 2π i / wavelength + phase),   dψ/dt = 2π f · direction
    ψ(t) = 2π f_p d_p t + δ(t): f_p, d_p the params, δ the gait's continuous state, dδ/dt = dψ/dt − 2π f_p d_p
    (δ = 0 while nothing is commanded: the wave is exactly 2π f t).
    "undulation" is that wave; "sidewinding" adds a second wave on ``second_joints``
    shifted by ``second_phase`` (π/2 classically). Other joints as joint_setpoints.
    Because ψ is integrated, a frequency changed during the run
    (input ``frequency``) changes the speed of the wave without a jump in the joints.

    Optional inputs (shape (1,), for a command source such as ros2_gait_commands): ``amplitude``
    (rad; sidewinding scales both waves by amplitude / the amplitude param), ``frequency`` (Hz, >= 0),
    ``wavelength`` (joints, > 0), ``direction`` (+1 or −1: which way the wave travels). NaN or
    unconnected: the parameter. A non-finite or out-of-range value is treated as NaN (the command
    source validates and logs).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Component, ContinuousState, Params, Uses

from .joint_selection import finite_or_raise, match, per_joint
from .setpoint_ports import command_input, setpoint_outputs


class JointSetpointsParams(Params):
    screw_speed: float = Field(0.0, description="rad/s, every screw joint")
    screw_direction: dict[str, float] = Field(default_factory=dict,
                                              description="multiplier (e.g. -1) by screw joint name/pattern")
    hold: dict[str, float] = Field(default_factory=dict, description="rad, held angle of non-screw joints")
    setpoints: dict[str, float] = Field(default_factory=dict, description="explicit value by joint name/pattern")


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
    robot = Uses(RobotModel)
    setpoint, rate = setpoint_outputs()

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
    direction: Literal[1, -1] = Field(1, description="+1 or −1: which way the wave travels along the body")
    offset: float = Field(0.0, description="rad")
    second_joints: str = Field("twist_*", description="sidewinding: pattern of the second wave's joints")
    second_amplitude: float = Field(0.2, description="rad")
    second_phase: float = Field(math.pi / 2, description="rad, shift of the second wave")


def command(value, default: float, low: float = -math.inf, strict: bool = False) -> float:
    """A command input's value (shape (1,)) if it is finite and above ``low`` (strictly with ``strict``),
    else ``default`` (NaN: not commanded; out of range: the command source rejects and logs it)."""
    v = float(value[0])
    if math.isfinite(v) and (v > low if strict else v >= low):
        return v
    return default


def command_direction(value, default: int) -> int:
    v = float(value[0])
    return int(v) if v in (1.0, -1.0) else default


_SERPENOID_INPUTS = ("amplitude", "frequency", "wavelength", "direction")


class SerpenoidGait(Component[SerpenoidParams]):
    type_name = "serpenoid_gait"
    robot = Uses(RobotModel)
    amplitude = command_input("rad")
    frequency = command_input("Hz")
    wavelength = command_input("1")
    direction = command_input("1")
    setpoint, rate = setpoint_outputs(_SERPENOID_INPUTS)

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
        # per wave joint: its index along its own wave and its wave's phase (the spatial phase is
        # −2π index / wavelength + that, recomputed when the wavelength is commanded)
        self._i = np.concatenate([np.arange(i.size, dtype=float) for i in idx])
        self._ph = np.concatenate([np.full(i.size, f) for i, f in zip(idx, ph)])
        self._amp = np.concatenate([np.full(i.size, a) for i, a in zip(idx, amp)])
        self._main = np.arange(self._idx.size) < idx[0].size

    def continuous_state(self):
        return ContinuousState(np.zeros(1), names=("phase_shift",))

    def _omega(self, u) -> float:
        """rad/s, dψ/dt: 2π f · direction, commanded or the params'."""
        p = self.p
        return 2.0 * np.pi * command(u.frequency, p.frequency, 0.0) * command_direction(u.direction, p.direction)

    def output(self, t, x, u, y):
        p = self.p
        lam = command(u.wavelength, p.wavelength, 0.0, strict=True)
        a = command(u.amplitude, p.amplitude, 0.0)
        if a == p.amplitude:
            amp = self._amp
        else:       # the main wave at a, the second scaled alike (kept when the param is 0)
            amp = np.where(self._main, a, self._amp * (a / p.amplitude if p.amplitude else 1.0))
        w = self._omega(u)
        arg = 2.0 * np.pi * p.frequency * p.direction * t + x[0] - 2.0 * np.pi * self._i / lam + self._ph
        y.setpoint[:] = self._base
        y.setpoint[self._idx] = p.offset + amp * np.sin(arg)
        y.rate[:] = 0.0
        y.rate[self._idx] = amp * w * np.cos(arg)

    def derivative(self, t, x, u, dx):
        dx[0] = self._omega(u) - 2.0 * np.pi * self.p.frequency * self.p.direction
