"""Joints past their URDF position limits: a watch.

Unless its ``joint_stops`` are enabled (components/multibody/joint_stops.py) the multibody integrates the
joint angles freely; a controller or a placement that asks for more than the hardware can bend gets it
silently. With stops on, a joint still goes past its limit by the stop's compliance (τ / k: give
``tolerance`` the stops' penetration at full effort) or by a placement that starts it there.

This monitor compares the DOF joint angles with the URDF's <limit lower upper> (continuous joints have
none) at its ``rate`` and reports each joint that went past a limit by more than ``tolerance``, with its
worst angle (``report()``: ``summary.json`` under ``reports/<name>``, printed by ``snakesim run``); with
``stop_on_violation`` the run ends there, naming the joint, angle and limit::

    excess_j = max(q_j − upper_j, lower_j − q_j, 0)      (rad)

in   joint_q[nj]      role joint_positions, from the multibody (continuous joints wrapped)
out  max_excess rad (the worst so far, any joint)
uses robot: RobotModel (the multibody's): joint names and limits
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import joint_shape
from snakesim.components.port_roles import JOINT_POSITIONS
from snakesim.framework import Component, Input, Output, Params, Uses

from .watch import RunningWorst, WorstSoFarOutput, require_rate


class JointLimitsParams(Params):
    tolerance: float = Field(1e-3, ge=0, description="rad, past a limit by more than this counts")
    stop_on_violation: bool = Field(False, description="end the run when a joint first goes past a limit")


class _Worst(RunningWorst):
    """Per-run scratch: each joint's worst excess past a limit (``worst``, rad), the angle it had then,
    and the first breach."""

    def __init__(self, nj: int):
        super().__init__(nj)
        self.angle = np.full(nj, np.nan)


class JointLimits(WorstSoFarOutput, Component[JointLimitsParams]):
    type_name = "joint_limits"
    WORST_OUTPUT = "max_excess"
    robot = Uses(RobotModel)

    joint_q = Input(shape=joint_shape, unit="rad", role=JOINT_POSITIONS)
    max_excess = Output(shape=(), unit="rad")

    def setup(self):
        require_rate(self)
        self._lo, self._hi = self.robot.position_limits()

    def make_cache(self, x, u, y):
        return _Worst(self.robot.nj)

    def update(self, t, xd, u):
        q = np.asarray(u.joint_q, float)
        excess = np.maximum(np.maximum(q - self._hi, self._lo - q), 0.0)
        w = u.cache
        worse = excess > w.worst
        w.worst[worse], w.angle[worse] = excess[worse], q[worse]
        j = w.end_sample(t, xd, self.p.tolerance, self.robot.joints, q)
        if j is not None and self.p.stop_on_violation:
            self.stop(f"joint {self.robot.joints[j]} at {q[j]:.4g} rad is past its limits "
                      f"[{self._lo[j]:.4g}, {self._hi[j]:.4g}] rad (joint stops off, or overpowered)")

    # -- the run's report (framework/run_reports.py) -------------------------------------------
    def report(self, cache, summary: dict) -> dict:
        """Every joint that went past a limit by more than the tolerance, worst first."""
        if cache is None:
            return {}
        tol = self.p.tolerance
        r = {"tolerance_rad": tol, "max_excess_rad": float(cache.worst.max(initial=0.0)),
             "past_limits": {self.robot.joints[j]: {"angle_rad": float(cache.angle[j]), "lower_rad": float(self._lo[j]),
                                                    "upper_rad": float(self._hi[j]),
                                                    "excess_rad": float(cache.worst[j])} for j in cache.over(tol)},
             **cache.first_report("joint", "angle_rad")}
        return r

    @staticmethod
    def format_report(r: dict) -> list[str]:
        """Lines for the terminal."""
        if not r["past_limits"]:
            return [f"every joint stayed within its URDF limits (tolerance {math.degrees(r['tolerance_rad']):.2g} deg)"]
        worst = ", ".join(f"{k} {math.degrees(v['angle_rad']):.1f} deg (limit ±{math.degrees(v['upper_rad']):.1f})"
                          if v["lower_rad"] == -v["upper_rad"] else
                          f"{k} {math.degrees(v['angle_rad']):.1f} deg (limits {math.degrees(v['lower_rad']):.1f}, "
                          f"{math.degrees(v['upper_rad']):.1f})" for k, v in list(r["past_limits"].items())[:4])
        return [f"joints past their URDF limits (joint stops off, or overpowered): {worst}"]
