"""A reference brace-and-climb controller for vertical mobility (paper 4.3): a baseline to beat.

The body is braced across a shaft (two walls, a tube) by one bend *amplitude* A that scales a
fixed bend pattern (default every bend joint +1: a C whose ends press one wall and middle the
other); A is regulated on the measured wall loads; the screws are braked until ``climb_start``
and then turn at the climb speeds while the brace is kept::

    load      L = mean (or min, ``regulate``) of the ``loads`` input over the screws (N):
              contact.screw_normal_force, or wall loads estimated from the FTS array
    brace     A_{k+1} = clip(A_k + T·clip(gain·(F* − L)/F*, −max_rate, max_rate), A_min, A_max)
              at every sample of period T (``rate``), in every phase: the brace is held while climbing
    lost      a screw whose load falls below lost_fraction·F* counts as out of contact; L then uses
              the min (recovery: the amplitude rises until every screw is back on a wall)
    set-points  bend/twist j: base_j + A·pattern_j (rad) (twist joints: + twist);
                screw j: 0 before climb_start, then speed·climb_sign_j (rad/s, the PID's velocity mode;
                its integral brakes the screws at 0)
    feed-forward  tau_ff[j] = A·torque_pattern_j (N·m): a pre-load in proportion to the amplitude
                (e.g. a placement's latched pre-load torques for A = 1 at the target load)

``target`` (F*) and ``speed`` are parameters, overridable at run time through the optional
``target_force`` and ``climb_speed`` inputs (wire a ROS 2 command or a schedule; NaN or
unconnected: the parameter). Descend with a negative speed.

in   loads[ns]        N, per screw wall load (feedthrough-free: sampled at the rate)
     target_force[1]  N (optional), climb_speed[1] rad/s (optional)
out  setpoint[nj]     rad (bend, twist) or rad/s (screws), the multibody's DOF joint order
     tau_ff[nj]       N·m, to the PID's feed-forward
     amplitude[1]     rad, A;  phase[1]: 0 brace/hold, 1 climbing;  load[1]: L, N
uses robot: RobotModel (the multibody's): joint names and kinds
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Component, Input, Output, Params, Uses

from .joint_selection import finite_or_raise, per_joint

A, PHASE, LOAD, NX = 0, 1, 2, 3


class BraceClimbParams(Params):
    target: float = Field(100.0, gt=0, description="N, wall load per screw the brace regulates to")
    regulate: Literal["mean", "min"] = Field("mean", description="which screw load the amplitude follows")
    gain: float = Field(0.5, gt=0, description="rad/s per unit relative load error")
    max_rate: float = Field(0.5, gt=0, description="rad/s, largest amplitude change")
    amplitude0: float = Field(0.0, description="rad, the starting amplitude")
    amplitude_min: float = Field(0.0, description="rad")
    amplitude_max: float = Field(1.2, description="rad, a brace never bends further")
    pattern: dict[str, float] = Field(default_factory=lambda: {"bend_*": 1.0},
                                      description="rad per unit amplitude, by bend joint name/pattern (unnamed: 0)")
    base: list[float] = Field(default_factory=list, description="rad, set-points at A = 0, every DOF joint "
                              "in URDF order (empty: 0; screws ignored)")
    torque_pattern: dict[str, float] = Field(default_factory=dict,
                                             description="N·m per unit amplitude, by joint name/pattern")
    twist: float = Field(0.0, description="rad, every twist joint")
    lost_fraction: float = Field(0.2, ge=0, lt=1, description="a screw below this share of the target is off the wall")
    climb_start: float = Field(float("inf"), description="s, screws start turning")
    speed: float = Field(0.0, description="rad/s, climb speed (negative: descend)")
    climb_signs: dict[str, float] = Field(default_factory=lambda: {"screw_*": 1.0},
                                          description="per screw joint/pattern factor on the speed")


class BraceClimb(Component[BraceClimbParams]):
    type_name = "brace_climb"
    Params = BraceClimbParams
    robot = Uses(RobotModel)

    loads = Input(shape=None, unit="N")
    target_force = Input(shape=(1,), unit="N", default=np.nan)
    climb_speed = Input(shape=(1,), unit="rad/s", default=np.nan)
    setpoint = Output(shape=lambda c: (c.robot.nj,), unit=None, feedthrough=(), names=lambda c: c.robot.joints)
    tau_ff = Output(shape=lambda c: (c.robot.nj,), unit="N*m", feedthrough=(), names=lambda c: c.robot.joints)
    amplitude = Output(shape=(1,), unit="rad", feedthrough=())
    phase = Output(shape=(1,), unit="1", feedthrough=())
    load = Output(shape=(1,), unit="N", feedthrough=())

    def setup(self):
        p, names = self.p, list(self.robot.joints)
        if self.rate is None:
            raise ValueError(f"{self.name}: brace_climb is a sampled controller: give it `rate: HZ`")
        if not p.amplitude_min <= p.amplitude0 <= p.amplitude_max:
            raise ValueError(f"{self.name}: need amplitude_min <= amplitude0 <= amplitude_max")
        finite_or_raise(p.pattern, f"{self.name}: pattern")
        finite_or_raise(p.climb_signs, f"{self.name}: climb_signs")
        kinds = np.array(self.robot.joint_kinds)
        self._bend, self._twist, self._screw = kinds == "bend", kinds == "twist", kinds == "screw"
        self._pattern = np.array(per_joint(names, p.pattern, f"{self.name}: pattern", 0.0), float) * self._bend
        nj = self.robot.nj
        if p.base and len(p.base) != nj:
            raise ValueError(f"{self.name}: base has {len(p.base)} values, the robot has {nj} DOF joints")
        self._base = (np.array(p.base, float) if p.base else np.zeros(nj)) * ~self._screw
        finite_or_raise(p.torque_pattern, f"{self.name}: torque_pattern")
        self._tau = np.array(per_joint(names, p.torque_pattern, f"{self.name}: torque_pattern", 0.0), float)
        self._signs = np.array(per_joint(names, p.climb_signs, f"{self.name}: climb_signs", 0.0), float) * self._screw

    def discrete_state(self):
        x = np.zeros(NX)
        x[A] = self.p.amplitude0
        return x

    def output(self, t, x, u, y):
        y.setpoint[:] = self._base + x[A] * self._pattern + self.p.twist * self._twist
        y.tau_ff[:] = x[A] * self._tau
        if x[PHASE]:
            s = float(u.climb_speed[0])
            y.setpoint[self._screw] = (s if s == s else self.p.speed) * self._signs[self._screw]
        y.amplitude[0], y.phase[0], y.load[0] = x[A], x[PHASE], x[LOAD]

    def update(self, t, xd, u):
        p, T = self.p, 1.0 / self.rate
        F = float(u.target_force[0])
        F = F if F == F and F > 0 else p.target
        loads = np.asarray(u.loads, float).ravel()
        lost = bool((loads < p.lost_fraction * F).any())
        L = float(loads.min() if (p.regulate == "min" or lost) else loads.mean()) if loads.size else 0.0
        rate = min(max(p.gain * (F - L) / F, -p.max_rate), p.max_rate)
        xd[A] = min(max(xd[A] + T * rate, p.amplitude_min), p.amplitude_max)
        xd[LOAD] = L
        xd[PHASE] = float(t >= p.climb_start)
