"""Screw speed phases: per-screw speed and direction switched at given times, joints locked (paper 4.2).

The lab traverse of paper 4.2 held the bend and twist actuators and ran the screws "in
various combinations of speed and direction". This source gives the PID those set-points:

    phase k (times[k] <= t < times[k+1]):  screw DOF j -> speeds[k][group or pattern]  (rad/s)
    before times[0], and screws a phase does not name:  0 rad/s
    bend/twist/other joints:                            hold[j] (rad), every phase

A phase is a mapping from screw joint names or glob patterns (``screw_front_0[0-4]``) or the
module groups ``all``, ``tail_half`` (modules 0 .. n/2 − 1) and ``head_half`` (n/2 .. n − 1) to a
speed; a group keeps a phase meaningful when ``--modules`` changes. The speed of a DOF is its
front screw's (the rear screw of a pair turns at −speed, the URDF mimic). Later keys win.

out  setpoint[nj]  rad (held joints) or rad/s (screws), the multibody's DOF joint order
     rate[nj]      rad/s, 0 (piecewise-constant set-points)
     phase[1]      index of the current phase (−1 before the first)
uses robot: RobotModel (the multibody's): joint names and kinds
"""

from __future__ import annotations

import fnmatch
import re

import numpy as np
from pydantic import Field, model_validator

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Component, Output, Params, Uses

from .joint_selection import finite_or_raise, per_joint
from .schedule import check_switch_times
from .setpoint_ports import setpoint_outputs

GROUPS = ("all", "tail_half", "head_half")
_MODULE = re.compile(r"_(\d+)$")


class ScrewScheduleParams(Params):
    times: list[float] = Field(default_factory=list, description="s, start of each phase, strictly increasing")
    speeds: list[dict[str, float]] = Field(default_factory=list,
                                           description="rad/s per phase, by screw name/pattern or group")
    hold: dict[str, float] = Field(default_factory=dict, description="rad, held angle of non-screw joints")

    @model_validator(mode="after")
    def _check(self):
        check_switch_times(self.times, self.speeds, "speeds")
        return self


def screw_groups(robot: RobotModel) -> dict[str, np.ndarray]:
    """Masks of the screw DOFs in each group, from the module index ending each screw's name."""
    names = robot.joints
    screw = np.array([k == "screw" for k in robot.joint_kinds], dtype=bool)
    module = np.array([int(m.group(1)) if (m := _MODULE.search(n)) else -1 for n in names])
    n_mod = module[screw].max() + 1 if screw.any() else 0
    half = n_mod // 2
    return {"all": screw, "tail_half": screw & (module < half), "head_half": screw & (module >= half)}


def phase_vector(names, speeds: dict[str, float], base: np.ndarray, groups, owner: str) -> np.ndarray:
    """The set-point vector of one phase: ``base`` with the named screws' speeds written in."""
    out = base.copy()
    screw = groups["all"]
    for key, value in speeds.items():           # a handful of keys per phase, at set-up only
        if key in groups:
            mask = groups[key]
        else:
            mask = np.array([n == key or fnmatch.fnmatchcase(n, key) for n in names])
            if not mask.any():
                raise ValueError(f"{owner}: speeds: '{key}' matches no joint; valid: {', '.join(GROUPS)} "
                                 f"or screw joints {', '.join(n for n, s in zip(names, screw) if s)}")
            if (mask & ~screw).any():
                raise ValueError(f"{owner}: speeds: '{key}' names non-screw joints "
                                 f"{[n for n, m, s in zip(names, mask, screw) if m and not s]}")
        out[mask] = value
    return out


class ScrewSchedule(Component[ScrewScheduleParams]):
    type_name = "screw_schedule"
    robot = Uses(RobotModel)
    setpoint, rate = setpoint_outputs()
    phase = Output(shape=(1,), unit="1", feedthrough=())

    def setup(self):
        p, names = self.p, list(self.robot.joints)
        finite_or_raise(p.hold, f"{self.name}: hold")
        for k, s in enumerate(p.speeds):
            finite_or_raise(s, f"{self.name}: speeds[{k}]")
        groups = screw_groups(self.robot)
        base = np.where(groups["all"], 0.0, np.array(per_joint(names, p.hold, f"{self.name}: hold", 0.0), dtype=float))
        self._t = np.asarray(p.times, dtype=float)
        self._table = np.array([base] + [phase_vector(names, s, base, groups, f"{self.name}: speeds[{k}]")
                                         for k, s in enumerate(p.speeds)])
        limit = np.where(groups["all"], self.robot.velocity_limits(), np.inf)
        over = np.argwhere(np.abs(self._table[1:]) > limit)
        if over.size:
            k, j = over[0]
            raise ValueError(f"{self.name}: speeds[{k}]: screw joint '{names[j]}' at {self._table[k + 1, j]:g} rad/s "
                             f"exceeds its URDF velocity limit {limit[j]:g} rad/s (the motor cannot follow it)")

    def make_cache(self, x, u, y):
        """The phase the outputs hold (-1: none yet): they are rewritten only when it changes."""
        return _Held()

    def output(self, t, x, u, y):
        k = int(self._t.searchsorted(t, side="right"))
        held = u.cache
        if k != held.k:
            y.setpoint[:] = self._table[k]
            y.rate[:] = 0.0
            y.phase[0] = k - 1
            held.k = k


class _Held:
    __slots__ = ("k",)

    def __init__(self):
        self.k = -1
