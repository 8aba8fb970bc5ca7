"""The melt-in mobility judge: after the dwell, did the braced robot climb, or are its screws melted in?

Paper 4.3.2's failure: the screws melted into the ice during a static hold and the controller could not pull
the robot out (an irrecoverable vertical-mobility failure). Sampled at its ``rate``::

    h(t)      height (+z) of ``reference_link``'s origin (default: the root)
    h_0       h at the first sample at or after ``dwell`` (the climb's start); climb = h − h_0
    made      climb >= min_climb at a sample before dwell + window: the robot pulled itself out of its
              grooves; with ``stop_on_success`` the run ends there as a success (the bench's runs need
              nothing after it)
    failed    no climb of min_climb by dwell + window; or, from the dwell on, a module tilted past ``max_tilt``
              (60°, the mobility monitor's rule, monitors/tilt.py) from the vertical: the brace lost its
              shape. Give the scene's mobility monitor a larger max_tilt than this judge's, so that the
              judge speaks. Either way a failure (kind ``mobility``, exit 12) named by its mechanism, with
              the tilt or the missing climb as its consequence:

    embedded_screws   a screw whose groove wall holds it: F_g,s > μ m_s F_n,s (groove_drag.wall_force, the
                      force to push it out across the wall, beyond the thread depth, against the most its
                      contact's friction can push: the material's ``mu`` × the contact's μ scale m_s ×
                      its normal force). The field test's "too deep to pull itself out".
    sunk_screws       no screw held so, but the deepest is ≥ ``sunk_depth`` in the ice: the melt-in lowered
                      the walls under the screws and the brace, pressing on them, widened and lost its
                      shape (in melt-dwell-climb each mm of sinkage turns the modules towards the
                      horizontal: ~55° after a short dwell, past 60° at ~13 mm; lifting the screws out of
                      their grooves squeezes the brace, wall loads of 1–2 kN).
    climb_failed      neither: the screws barely melted in; not a melt-in failure.

    Judged from the screws at the dwell's end (the first sample of the climb: what it has to pull out
    of; at the tilt itself the squeezed brace's wall loads are spikes). The stop reason starts with the
    name ("embedded_screws at the dwell's end: screw_front_02 21.3 mm in the ice, thread 17.5 mm: pushing
    it out of its groove takes 439 N, its traction gives 120 N; the brace lost its shape (...) after
    climbing 2 mm, dwell 40 s"); reports/watch has ``failure`` and ``at_failure``: each screw's
    penetration, wall force and traction then, and the largest tilt.

in   link_poses[nl, 7]   the multibody's
     penetration[ns] m   screw_heat.penetration (for the message and the report; optional)
     wall_force[ns] N    groove_drag.wall_force (optional: 0, no groove wall)
     normal_force[ns] N  contact.screw_normal_force (optional: 0)
     mu_scale[ns]        the contact's screw_mu_scale (screw_heat.mu_scale; optional: 1)
out  climb[1] m (h − h_0 after the dwell, 0 before), judged[1] (0 waiting, 1 climbed, −1 failed)
uses robot: RobotModel (the multibody's): the reference link, the screws' names
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
    mu: float = Field(1.0, gt=0, description="μ of the screw contact's material (the scene's), for the traction")
    thread_depth: float = Field(0.0175, gt=0, description="m, h_t (screw_heat's), for the message")
    sunk_depth: float = Field(0.005, gt=0, description="m: a failure with a screw at least this deep in the ice "
                              "is sunk_screws, one with none is climb_failed")


class MeltClimbWatch(Component[MeltClimbWatchParams]):
    type_name = "melt_climb_watch"
    robot = Uses(RobotModel)

    link_poses = Input(shape=link_shape(7), unit=None)
    penetration = Input(shape=None, unit="m", default=0.0)
    wall_force = Input(shape=None, unit="N", default=0.0)
    normal_force = Input(shape=None, unit="N", default=0.0)
    mu_scale = Input(shape=None, unit="1", default=1.0)
    climb = Output(shape=(1,), unit="m", feedthrough=())
    judged = Output(shape=(1,), unit="1", feedthrough=())

    def setup(self):
        if self.rate is None:
            raise ValueError(f"{self.name}: melt_climb_watch samples at a rate: give it `rate: HZ`")
        self._ref, self.reference_name = reference_link(self, self.p.reference_link)
        self._tilt = TiltRule(self.name, self.robot.links, self.p)
        from snakesim.components.contact.robot_screws import screw_layout
        self.screw_names = tuple(self.robot.derived(screw_layout).names)

    def discrete_state(self):
        return np.zeros(NX)

    def make_cache(self, x, u, y):
        return SimpleNamespace(xd=None, deepest=0.0, failure=None, start=None)

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
            c.start = self._screws_now(u)          # what the climb has to pull out of: the dwell's end
        xd[CLIMB] = h - xd[H0]
        poses = np.asarray(u.link_poses)[self._tilt.rows]
        tilt = self._tilt.angles(quat_axes(poses, self._tilt.axis))
        worst = float(tilt.max()) if tilt.size else 0.0
        if worst > p.max_tilt:
            xd[JUDGED], xd[T_JUDGED] = -1.0, t
            self._fail(u, f"the brace lost its shape ({self._tilt.failure(tilt, worst)}) after climbing "
                          f"{1e3 * xd[CLIMB]:.0f} mm", math.degrees(worst))
            return
        if xd[CLIMB] >= p.min_climb:
            xd[JUDGED], xd[T_JUDGED] = 1.0, t
            if p.stop_on_success:
                self.stop(f"climb made after dwell {p.dwell:g} s: {1e3 * xd[CLIMB]:.0f} mm in "
                          f"{t - p.dwell:.3g} s", outcome="success")
        elif t >= p.dwell + p.window - 1e-9:
            xd[JUDGED], xd[T_JUDGED] = -1.0, t
            self._fail(u, f"climbed {1e3 * xd[CLIMB]:.0f} mm in {p.window:g} s, {1e3 * p.min_climb:.0f} mm "
                          f"needed", math.degrees(worst))

    def _screws_now(self, u) -> tuple:
        """(penetration m, groove wall force N, traction μ m_s F_n N) per screw, copies."""
        pen = np.atleast_1d(np.array(u.penetration, float))
        n = pen.size
        wall = np.broadcast_to(np.asarray(u.wall_force, float), (n,)).copy()
        traction = self.p.mu * np.broadcast_to(np.asarray(u.mu_scale, float), (n,)) * np.maximum(
            np.broadcast_to(np.asarray(u.normal_force, float), (n,)), 0.0)
        return pen, wall, traction

    def _fail(self, u, consequence: str, tilt_deg: float) -> None:
        """Stop with the mechanism's name (module docstring), judged from the screws at the dwell's end, and
        ``consequence``; keep it for the report."""
        p = self.p
        pen, wall, traction = u.cache.start if u.cache.start is not None else self._screws_now(u)
        n = pen.size
        held = wall - traction
        names = self._screw_names(n)
        if n and held.max() > 0.0:
            s = int(np.argmax(held))
            name = "embedded_screws"
            why = (f"{names[s]} {1e3 * pen[s]:.1f} mm in the ice, thread {1e3 * p.thread_depth:.1f} mm: pushing it "
                   f"out of its groove takes {wall[s]:.0f} N, its traction gives {traction[s]:.0f} N")
        else:
            s = int(np.argmax(pen)) if n else 0
            name = "sunk_screws" if n and pen[s] >= p.sunk_depth else "climb_failed"
            why = (f"{names[s]} {1e3 * pen[s]:.1f} mm in the ice (thread {1e3 * p.thread_depth:.1f} mm), "
                   f"no screw held by its groove wall" if n else "no penetration wired")
        u.cache.failure = {"failure": name, "screw": names[s] if n else None,
                           "penetration_mm": [1e3 * float(d) for d in pen], "wall_force_N": [float(f) for f in wall],
                           "traction_N": [float(f) for f in traction], "max_tilt_deg": tilt_deg}
        self.stop(f"{name} at the dwell's end: {why}; {consequence}, dwell {p.dwell:g} s", kind="mobility")

    def _screw_names(self, n: int) -> tuple:
        """The robot's screws (metadata order, as screw_heat's ports), or numbers if the inputs' size differs."""
        return self.screw_names if len(self.screw_names) == n else tuple(f"screw {i}" for i in range(n))

    # -- the run's report (framework/run_reports.py) ---------------------------------------------
    def report(self, cache, summary: dict) -> dict:
        """The dwell, the climb after it and the verdict."""
        x = cache.xd if cache is not None and cache.xd is not None else np.zeros(NX)
        failure = cache.failure if cache is not None else None
        verdict = {1.0: "climbed", -1.0: "failed"}.get(float(x[JUDGED]), "not_judged")
        return {"dwell_s": self.p.dwell, "window_s": self.p.window, "climb_m": float(x[CLIMB]),
                "min_climb_m": self.p.min_climb, "verdict": verdict,
                "judged_at_s": float(x[T_JUDGED]) if x[JUDGED] else None,
                "deepest_penetration_mm": 1e3 * (cache.deepest if cache is not None else 0.0),
                **({"failure": failure["failure"], "at_failure": failure} if failure else {})}

    @staticmethod
    def format_report(r: dict) -> list[str]:
        verdict = r.get("failure", r["verdict"])
        return [f"dwell {r['dwell_s']:g} s: {verdict} (climb {1e3 * r['climb_m']:.0f} mm after the dwell, "
                f"deepest screw {r['deepest_penetration_mm']:.1f} mm)"]
