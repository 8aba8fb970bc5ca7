"""The melt-in mobility judge: after the dwell, did the braced robot climb, or are its screws melted in?

Paper 4.3.2's failure: the screws melted into the ice during a static hold and the controller could not pull
the robot out (an irrecoverable vertical-mobility failure). Sampled at its ``rate``::

    h(t)      height (+z) of ``reference_link``'s origin (default: the root)
    h_0       h at the first sample at or after ``dwell`` (the climb's start); climb = h − h_0
    made      climb >= min_climb at a sample before dwell + window: the robot pulled itself out of its
              grooves; with ``stop_on_success`` the run ends there as a success (the bench's runs need
              nothing after it)
    failed    no climb of min_climb by dwell + window: failure (kind ``mobility``, exit 12) "screws melted
              in: climb failed after dwell X s (...)", with the climb and the deepest screw's penetration;
              or, from the dwell on, a module tilted past ``max_tilt`` (60°, the mobility monitor's rule,
              monitors/tilt.py) from the vertical: the brace lost its shape, named the same way. In
              melt-dwell-climb this is how a long dwell fails first: each mm of sinkage widens the braced C
              and turns its modules towards the horizontal (~55° after a short dwell, past 60° at ~13 mm),
              and lifting the screws out of their grooves squeezes the brace (wall loads of 1–2 kN). Give
              the scene's mobility monitor a larger max_tilt than this judge's, so that the judge speaks.

in   link_poses[nl, 7]   the multibody's
     penetration[ns] m   screw_heat.penetration (for the message and the report; optional)
out  climb[1] m (h − h_0 after the dwell, 0 before), judged[1] (0 waiting, 1 climbed, −1 failed)
uses robot: RobotModel (the multibody's): the reference link
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.components.monitors import reference_link
from snakesim.components.monitors.tilt import TiltRule
from snakesim.components.monitors.vertical_mobility import quat_axes
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.framework import Component, Input, Output, Params, Uses

H0, STARTED, CLIMB, JUDGED, T_JUDGED, NX = range(6)


class MeltClimbWatchParams(Params):
    dwell: float = Field(..., ge=0, description="s, the static hold before the climb starts (the scene's)")
    window: float = Field(4.0, gt=0, description="s after the dwell within which the climb must be made")
    min_climb: float = Field(0.05, gt=0, description="m, the climb that counts as made")
    reference_link: str | None = Field(None, description="link whose height is measured (default: the root)")
    stop_on_success: bool = Field(True, description="end the run (success) once the climb is made")
    tilt_links: list[str] = Field(default_factory=lambda: ["module_*"], description="links whose axis is checked")
    axis: tuple[float, float, float] = Field((1.0, 0.0, 0.0), description="body axis in each link frame")
    vertical: Literal["up", "down", "line"] = "line"
    max_tilt: float = Field(math.radians(60.0), gt=0, le=math.pi, description="rad, from the dwell on: the "
                            "mobility monitor's rule (a short-dwell climb of melt-dwell-climb stays within ~55°)")
    gravity: tuple[float, float, float] = Field((0.0, 0.0, -9.81), description="world; its direction only")


class MeltClimbWatch(Component[MeltClimbWatchParams]):
    type_name = "melt_climb_watch"
    robot = Uses(RobotModel)

    link_poses = Input(shape=link_shape(7), unit=None)
    penetration = Input(shape=None, unit="m", default=0.0)
    climb = Output(shape=(1,), unit="m", feedthrough=())
    judged = Output(shape=(1,), unit="1", feedthrough=())

    def setup(self):
        if self.rate is None:
            raise ValueError(f"{self.name}: melt_climb_watch samples at a rate: give it `rate: HZ`")
        self._ref, self.reference_name = reference_link(self, self.p.reference_link)
        self._tilt = TiltRule(self.name, self.robot.links, self.p)

    def discrete_state(self):
        return np.zeros(NX)

    def make_cache(self, x, u, y):
        return SimpleNamespace(xd=None, deepest=0.0)

    def output(self, t, x, u, y):
        y.climb[0], y.judged[0] = x[CLIMB], x[JUDGED]

    def update(self, t, xd, u):
        p, c = self.p, u.cache
        c.xd = xd
        pen = np.asarray(u.penetration, float)
        c.deepest = max(c.deepest, float(pen.max(initial=0.0)))
        if t < p.dwell - 1e-9 or xd[JUDGED]:
            return
        h = float(u.link_poses[self._ref, 2])
        if not xd[STARTED]:
            xd[STARTED], xd[H0] = 1.0, h
        xd[CLIMB] = h - xd[H0]
        poses = np.asarray(u.link_poses)[self._tilt.rows]
        tilt = self._tilt.angles(quat_axes(poses, self._tilt.axis))
        worst = float(tilt.max()) if tilt.size else 0.0
        if worst > p.max_tilt:
            xd[JUDGED], xd[T_JUDGED] = -1.0, t
            self.stop(f"screws melted in: climb failed after dwell {p.dwell:g} s ({self._tilt.failure(tilt, worst)}"
                      f" after climbing {1e3 * xd[CLIMB]:.0f} mm; deepest screw {1e3 * c.deepest:.1f} mm in the ice)",
                      kind="mobility")
            return
        if xd[CLIMB] >= p.min_climb:
            xd[JUDGED], xd[T_JUDGED] = 1.0, t
            if p.stop_on_success:
                self.stop(f"climb made after dwell {p.dwell:g} s: {1e3 * xd[CLIMB]:.0f} mm in "
                          f"{t - p.dwell:.3g} s", outcome="success")
        elif t >= p.dwell + p.window - 1e-9:
            xd[JUDGED], xd[T_JUDGED] = -1.0, t
            self.stop(f"screws melted in: climb failed after dwell {p.dwell:g} s (climbed {1e3 * xd[CLIMB]:.0f} mm "
                      f"in {p.window:g} s, {1e3 * p.min_climb:.0f} mm needed; deepest screw "
                      f"{1e3 * c.deepest:.1f} mm in the ice)", kind="mobility")

    # -- the run's report (framework/run_reports.py) ---------------------------------------------
    def report(self, cache, summary: dict) -> dict:
        """The dwell, the climb after it and the verdict."""
        x = cache.xd if cache is not None and cache.xd is not None else np.zeros(NX)
        verdict = {1.0: "climbed", -1.0: "melted_in"}.get(float(x[JUDGED]), "not_judged")
        return {"dwell_s": self.p.dwell, "window_s": self.p.window, "climb_m": float(x[CLIMB]),
                "min_climb_m": self.p.min_climb, "verdict": verdict,
                "judged_at_s": float(x[T_JUDGED]) if x[JUDGED] else None,
                "deepest_penetration_mm": 1e3 * (cache.deepest if cache is not None else 0.0)}

    @staticmethod
    def format_report(r: dict) -> list[str]:
        return [f"dwell {r['dwell_s']:g} s: {r['verdict']} (climb {1e3 * r['climb_m']:.0f} mm after the dwell, "
                f"deepest screw {r['deepest_penetration_mm']:.1f} mm)"]
