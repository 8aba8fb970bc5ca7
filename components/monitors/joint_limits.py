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
from snakesim.components.port_roles import JOINT_POSITIONS
from snakesim.framework import Component, Input, Output, Params, Uses


class JointLimitsParams(Params):
    tolerance: float = Field(1e-3, ge=0, description="rad, past a limit by more than this counts")
    stop_on_violation: bool = Field(False, description="end the run when a joint first goes past a limit")


class _Worst:
    """Per-run scratch: the worst angle past each limit (excess, angle) and when the first one happened."""

    def __init__(self, nj: int):
        self.excess = np.zeros(nj)
        self.angle = np.full(nj, np.nan)
        self.first: tuple[float, str, float] | None = None


class JointLimits(Component[JointLimitsParams]):
    type_name = "joint_limits"
    robot = Uses(RobotModel)

    joint_q = Input(shape=lambda c: (c.robot.nj,), unit="rad", role=JOINT_POSITIONS)
    max_excess = Output(shape=(), unit="rad")

    def setup(self):
        if self.rate is None:
            raise ValueError(f"{self.name}: joint_limits samples at a rate: give it `rate: HZ`")
        self._lo, self._hi = self.robot.position_limits()

    def make_cache(self, x, u, y):
        return _Worst(self.robot.nj)

    def discrete_state(self):
        return np.zeros(1)

    def output(self, t, x, u, y):
        y.max_excess[...] = x[0]

    def update(self, t, xd, u):
        q = np.asarray(u.joint_q, float)
        excess = np.maximum(np.maximum(q - self._hi, self._lo - q), 0.0)
        w = u.cache
        worse = excess > w.excess
        w.excess[worse], w.angle[worse] = excess[worse], q[worse]
        xd[0] = float(w.excess.max(initial=0.0))
        if w.first is None and xd[0] > self.p.tolerance:
            j = int(np.argmax(w.excess))
            w.first = (t, self.robot.joints[j], float(q[j]))
            if self.p.stop_on_violation:
                self.stop(f"joint {self.robot.joints[j]} at {q[j]:.4g} rad is past its limits "
                          f"[{self._lo[j]:.4g}, {self._hi[j]:.4g}] rad (joint stops off, or overpowered)")

    # -- the run's report (framework/run_reports.py) -------------------------------------------
    def report(self, cache, summary: dict) -> dict:
        """Every joint that went past a limit by more than the tolerance, worst first."""
        if cache is None:
            return {}
        tol = self.p.tolerance
        order = [j for j in np.argsort(-cache.excess) if cache.excess[j] > tol]
        r = {"tolerance_rad": tol, "max_excess_rad": float(cache.excess.max(initial=0.0)),
             "past_limits": {self.robot.joints[j]: {"angle_rad": float(cache.angle[j]), "lower_rad": float(self._lo[j]),
                                                    "upper_rad": float(self._hi[j]),
                                                    "excess_rad": float(cache.excess[j])} for j in order}}
        if cache.first is not None:
            r["first"] = {"time_s": cache.first[0], "joint": cache.first[1], "angle_rad": cache.first[2]}
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
