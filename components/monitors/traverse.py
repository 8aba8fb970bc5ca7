"""A traverse's evaluation: how far and how fast the robot went along a path, and how well it kept to it.

The horizontal counterpart of ``vertical_mobility_evaluation`` (paper 4.3.1's test, for a
channel or a surface run): sampled at its ``rate`` from the reference link's origin p(t)
(default the root link) and reported at the end of the run (``report()``: ``summary.json``
under ``reports/<name>``, printed by ``snakesim run``; also usable as campaign metrics)::

    û          ``direction`` normalised (world frame)
    s(t)       (p(t) − p(t₀))·û, the distance along the path since ``start`` (t₀: first sample at t ≥ start)
    lateral    ‖(p − p(t₀)) − s û‖, the largest over the run (m): how far it strayed off the path
    speed      mean s/(t − t₀) over the run, and the steady speed: least-squares slope of s(t) over
               the last ``steady_window`` seconds (m/s)
    made good  ‖(p − p(t₀))_xy‖ at the last sample, the horizontal distance made good whatever the path's
               direction, and the horizontal path length Σ ‖Δp_xy‖ over the samples (m): a schedule that goes
               out and back makes little good over a long path
    reference  optional ``reference_speed`` (m/s) to compare with (e.g. a screw's analytic steady speed,
               components/contact/steady_state.py, or its no-slip advance ω r tan λ):
               efficiency = steady / reference

in   link_poses[nl, 7]   role link_poses, from the multibody
out  distance m (s at the last sample; 0 before start), lateral m (largest so far)
uses robot: RobotModel (the multibody's): link names and rows
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.components.monitors import reference_link
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.components.port_roles import LINK_POSES
from snakesim.framework import Component, Input, Output, Params, Uses

from .watch import require_rate

Vec3 = tuple[float, float, float]

STARTED, T0, P0X, P0Y, P0Z, S, LATERAL, T_LAST, NX = range(9)


class TraverseEvaluationParams(Params):
    direction: Vec3 = Field((1.0, 0.0, 0.0), description="the path's direction, world frame (normalised)")
    start: float = Field(0.0, ge=0, description="s, distances count from the first sample at or after this")
    reference_link: str | None = Field(None, description="link whose origin is followed (default: the root)")
    steady_window: float = Field(2.0, gt=0, description="s, the last stretch the steady speed is fitted over")
    reference_speed: float | None = Field(None, gt=0, description="m/s, a speed the steady speed is compared with (optional)")


class _Track:
    """Per-run scratch: the sampled (t, s) since the start, and the state at the end."""

    def __init__(self):
        self.t: list[float] = []
        self.s: list[float] = []
        self.xy: list[tuple[float, float]] = []
        self.xd = None


class TraverseEvaluation(Component[TraverseEvaluationParams]):
    type_name = "traverse_evaluation"
    robot = Uses(RobotModel)

    link_poses = Input(shape=link_shape(7), unit=None, role=LINK_POSES)
    distance = Output(shape=(), unit="m")
    lateral = Output(shape=(), unit="m")

    def setup(self):
        p = self.p
        require_rate(self)
        d = np.array(p.direction, float)
        if not np.linalg.norm(d) > 0:
            raise ValueError(f"{self.name}: direction needs a non-zero vector, got {p.direction}")
        self._dir = d / np.linalg.norm(d)
        self._ref, self.reference_name = reference_link(self, p.reference_link)

    def discrete_state(self):
        return np.zeros(NX)

    def make_cache(self, x, u, y):
        return _Track()

    def output(self, t, x, u, y):
        y.distance[...] = x[S]
        y.lateral[...] = x[LATERAL]

    def update(self, t, xd, u):
        w = u.cache
        w.xd = xd
        if t < self.p.start - 1e-12:
            return
        pos = np.asarray(u.link_poses[self._ref, :3], float)
        if not xd[STARTED]:
            xd[STARTED], xd[T0], xd[P0X:P0Z + 1] = 1.0, t, pos
        d = pos - xd[P0X:P0Z + 1]
        s = float(d @ self._dir)
        xd[S], xd[T_LAST] = s, t
        xd[LATERAL] = max(xd[LATERAL], float(np.linalg.norm(d - s * self._dir)))
        w.t.append(t)
        w.s.append(s)
        w.xy.append((float(pos[0]), float(pos[1])))

    # -- the run's report (framework/run_reports.py) -------------------------------------------
    def report(self, cache, summary: dict) -> dict:
        """Distance, mean and steady speed along the path, the largest lateral excursion."""
        p = self.p
        if cache is None or cache.xd is None or not cache.xd[STARTED]:
            return {"started": False, "start_s": p.start}
        x, t, s = cache.xd, np.asarray(cache.t), np.asarray(cache.s)
        elapsed = float(x[T_LAST] - x[T0])
        late = t >= t[-1] - p.steady_window
        steady = float(np.polyfit(t[late], s[late], 1)[0]) if late.sum() >= 2 else None
        xy = np.asarray(cache.xy)
        r = {"started": True, "start_s": float(x[T0]), "elapsed_s": elapsed,
             "direction": [float(v) for v in self._dir], "reference_link": self.reference_name,
             "distance_m": float(x[S]), "lateral_max_m": float(x[LATERAL]),
             "made_good_m": float(np.hypot(*(xy[-1] - xy[0]))),
             "path_length_m": float(np.hypot(*np.diff(xy, axis=0).T).sum()),
             "mean_speed_m_s": float(x[S]) / elapsed if elapsed > 0 else None,
             "steady_speed_m_s": steady, "steady_window_s": p.steady_window}
        if p.reference_speed is not None:
            r["reference_speed_m_s"] = p.reference_speed
            r["efficiency"] = steady / p.reference_speed if steady is not None else None
        return r

    @staticmethod
    def format_report(r: dict) -> list[str]:
        """Lines for the terminal."""
        if not r.get("started"):
            return [f"traverse: never started (start {r['start_s']:.3g} s)"]
        line = (f"traverse: {r['distance_m']:+.3g} m along the path in {r['elapsed_s']:.3g} s, steady "
                f"{r['steady_speed_m_s']:.3g} m/s over the last {r['steady_window_s']:.3g} s")
        if r.get("efficiency") is not None:
            line += f" ({100 * r['efficiency']:.0f} % of the reference {r['reference_speed_m_s']:.3g} m/s)"
        return [line, f"largest lateral excursion: {r['lateral_max_m'] * 1e3:.3g} mm; made good "
                      f"{r['made_good_m']:.3g} m over a {r['path_length_m']:.3g} m path (horizontal)"]
