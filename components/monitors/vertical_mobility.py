"""The field test's evaluation of a vertical-mobility controller (paper 4.3.1), as one component.

The Athabasca integration test judged a control strategy in order: did it (1) make contact
with the surface, (2) hold a static position supporting its own weight for a set time,
(3) how far did it travel vertically before (4) a mobility failure. This component measures
exactly those, sampled at its ``rate``, and reports them at the end of the run
(``report()``: ``summary.json`` under ``reports/<name>``, printed by ``snakesim run``)::

    h(t)        height (·û, û = −g/|g|) of ``reference_link``'s origin (default: the root link)
    F(t)        Σ of the ``normal_force`` input (any shape: contact.normal_force, screw_normal_force, ...)
    contact     first sample with F > contact_force: t_contact, h_c = h(t_contact)
    hold        after contact, the longest interval [t_a, t_b] of samples whose heights all lie
                within a band of width drift_tolerance (max h − min h <= tol over the interval),
                found exactly by a sliding window (monotonic deques); held = t_b − t_a >= hold_time
    distance    from h_c: up = max(h − h_c), down = max(h_c − h), net = h − h_c (at the last sample)
    failure     the mobility monitor's rule (components/monitors/tilt.py): θ_j between the
                body axis R_j·axis of each ``tilt_links`` link and the vertical (``vertical``
                up/down/line) beyond max_tilt (60°); else the run's own stop reason if it stopped
                early (another monitor, a stop condition, the integrator); else none
    tether      optional ``tension`` input: largest tension after contact and the fraction of
                post-contact samples at or below slack_tension (the belay carried no load)

Link rotations come from the poses' quaternions ([x, y, z, qx, qy, qz, qw]), so the component
needs only the LINK_POSES port. Every metric is a function of the sampled inputs alone: a
scripted run (tests/monitors/test_vertical_mobility.py) gives them exactly.

in   link_poses[nl, 7]   role link_poses, from the multibody
     normal_force[...]   N, summed (unconnected: contact is never made)
     tension[...]        N, the tether's (optional; NaN: no tether)
out  contact_made, t_contact s (NaN before), hold_time s (current window), max_hold_time s,
     held (1 once max_hold_time >= hold_time), climb m (net), max_up m, max_down m,
     max_tilt rad, failed
uses robot: RobotModel (the multibody's): link names and rows
"""

from __future__ import annotations

import math
from collections import deque
from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.components.monitors import reference_link
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.components.port_roles import LINK_POSES
from snakesim.framework import Component, Input, Output, Params, Uses

from .tilt import TiltRule
from .watch import contact_hold_outputs, require_rate

Vec3 = tuple[float, float, float]

# discrete state layout (finite values only)
(STARTED, CONTACT, T_CONTACT, H_C, HOLD, MAX_HOLD, HOLD_A, HOLD_B, UP, DOWN, NET, FAILED, T_FAIL,
 MAX_TILT, T_LAST, TMAX, NSLACK, NSAMP, NX) = range(19)


def quat_axes(poses: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """R(q)·axis for each row [x, y, z, qx, qy, qz, qw] of ``poses``: (n, 3)."""
    v = poses[:, 3:6]
    w = poses[:, 6:7]
    t = 2.0 * np.cross(v, np.broadcast_to(axis, v.shape))
    return axis + w * t + np.cross(v, t)


class VerticalMobilityParams(Params):
    contact_force: float = Field(5.0, ge=0, description="N, total normal force above which contact is made")
    hold_time: float = Field(10.0, gt=0, description="s, the static hold the test requires")
    drift_tolerance: float = Field(0.005, gt=0, description="m, band of heights a hold stays within")
    reference_link: str | None = Field(None, description="link whose height is measured (default: the root)")
    tilt_links: list[str] = Field(default_factory=lambda: ["module_*"], description="links whose axis is checked")
    axis: Vec3 = Field((1.0, 0.0, 0.0), description="body axis in each link frame")
    vertical: Literal["up", "down", "line"] = "line"
    max_tilt: float = Field(math.radians(60.0), gt=0, le=math.pi, description="rad, mobility failure beyond")
    stop_on_failure: bool = Field(True, description="end the run at a mobility failure")
    gravity: Vec3 = Field((0.0, 0.0, -9.81), description="direction of gravity, world (magnitude unused)")
    slack_tension: float = Field(1.0, ge=0, description="N, tether tension at or below which it is slack")


class _Window:
    """Per-run scratch: the sampled heights since contact and the sliding window's deques."""

    def __init__(self):
        self.t: list[float] = []
        self.h: list[float] = []
        self.lo = 0
        self.dmax: deque = deque()
        self.dmin: deque = deque()
        self.fail_reason: str | None = None
        self.xd = None

    def push(self, t: float, h: float, tol: float) -> tuple[float, float]:
        """Add a sample; (t_a, t_b) of the longest band-limited window ending here."""
        i = len(self.t)
        self.t.append(t)
        self.h.append(h)
        while self.dmax and self.h[self.dmax[-1]] <= h:
            self.dmax.pop()
        self.dmax.append(i)
        while self.dmin and self.h[self.dmin[-1]] >= h:
            self.dmin.pop()
        self.dmin.append(i)
        while self.h[self.dmax[0]] - self.h[self.dmin[0]] > tol:
            self.lo += 1
            while self.dmax[0] < self.lo:
                self.dmax.popleft()
            while self.dmin[0] < self.lo:
                self.dmin.popleft()
        return self.t[self.lo], t


class VerticalMobilityEvaluation(Component[VerticalMobilityParams]):
    type_name = "vertical_mobility_evaluation"
    robot = Uses(RobotModel)

    link_poses = Input(shape=link_shape(7), unit=None, role=LINK_POSES)
    normal_force = Input(shape=None, unit="N", default=0.0)
    tension = Input(shape=None, unit="N", default=np.nan)
    contact_made, t_contact, hold_time, max_hold_time = contact_hold_outputs()
    held = Output(shape=(), unit="1")
    climb = Output(shape=(), unit="m")
    max_up = Output(shape=(), unit="m")
    max_down = Output(shape=(), unit="m")
    max_tilt = Output(shape=(), unit="rad")
    failed = Output(shape=(), unit="1")

    def setup(self):
        p = self.p
        require_rate(self)
        self._tilt = TiltRule(self.name, self.robot.links, p)
        self._up, self.tilt_names = self._tilt.up, self._tilt.names
        self._ref, self.reference_name = reference_link(self, p.reference_link)

    def discrete_state(self):
        return np.zeros(NX)

    def make_cache(self, x, u, y):
        return _Window()

    def _tilts(self, u) -> np.ndarray:
        return self._tilt.angles(quat_axes(np.asarray(u.link_poses)[self._tilt.rows], self._tilt.axis))

    def output(self, t, x, u, y):
        y.contact_made[...] = x[CONTACT]
        y.t_contact[...] = x[T_CONTACT] if x[CONTACT] else np.nan
        y.hold_time[...] = x[HOLD]
        y.max_hold_time[...] = x[MAX_HOLD]
        y.held[...] = float(x[MAX_HOLD] >= self.p.hold_time - 1e-9)
        y.climb[...] = x[NET]
        y.max_up[...] = x[UP]
        y.max_down[...] = x[DOWN]
        y.max_tilt[...] = x[MAX_TILT]
        y.failed[...] = x[FAILED]

    def update(self, t, xd, u):
        p, w = self.p, u.cache
        w.xd = xd
        xd[STARTED], xd[T_LAST] = 1.0, t
        tilt = self._tilts(u)
        worst = float(tilt.max()) if tilt.size else 0.0
        xd[MAX_TILT] = max(xd[MAX_TILT], worst)
        if worst > p.max_tilt and not xd[FAILED]:
            xd[FAILED], xd[T_FAIL] = 1.0, t
            w.fail_reason = self._tilt.failure(tilt, worst)
            if p.stop_on_failure:
                self.stop(w.fail_reason, kind="mobility")
        h = float(u.link_poses[self._ref, :3] @ self._up)
        F = float(np.sum(u.normal_force))
        if not xd[CONTACT]:
            if not (F > p.contact_force):
                return
            xd[CONTACT], xd[T_CONTACT], xd[H_C] = 1.0, t, h
        a, b = w.push(t, h, p.drift_tolerance)
        xd[HOLD] = b - a
        if xd[HOLD] > xd[MAX_HOLD]:
            xd[MAX_HOLD], xd[HOLD_A], xd[HOLD_B] = xd[HOLD], a, b
        d = h - xd[H_C]
        xd[NET], xd[UP], xd[DOWN] = d, max(xd[UP], d), max(xd[DOWN], -d)
        T = np.asarray(u.tension, float)
        if T.size and np.isfinite(T).all():
            xd[TMAX] = max(xd[TMAX], float(T.max(initial=0.0)))
            xd[NSLACK] += float(T.max(initial=0.0) <= p.slack_tension)
            xd[NSAMP] += 1.0

    # -- the run's report (framework/run_reports.py) -------------------------------------------
    def report(self, cache, summary: dict) -> dict:
        """The field test's table: contact, hold, vertical distance, failure (and the tether's load)."""
        p = self.p
        x = cache.xd if cache is not None and cache.xd is not None else np.zeros(NX)
        contact = bool(x[CONTACT])
        r = {
            "contact": {"made": contact, "time_s": float(x[T_CONTACT]) if contact else None,
                        "threshold_N": p.contact_force},
            "hold": {"longest_s": float(x[MAX_HOLD]), "from_s": float(x[HOLD_A]) if contact else None,
                     "to_s": float(x[HOLD_B]) if contact else None, "required_s": p.hold_time,
                     "achieved": bool(x[MAX_HOLD] >= p.hold_time - 1e-9), "drift_tolerance_m": p.drift_tolerance},
            "vertical_distance": {"reference_link": self.reference_name, "up_m": float(x[UP]),
                                  "down_m": float(x[DOWN]), "net_m": float(x[NET])},
            "max_tilt_deg": math.degrees(float(x[MAX_TILT])),
        }
        if x[FAILED]:
            r["failure"] = {"failed": True, "time_s": float(x[T_FAIL]), "reason": cache.fail_reason}
        elif summary is not None and summary.get("outcome", "success" if summary.get("completed", True)
                                                 else "failure") == "failure":   # a success stop is no failure
            r["failure"] = {"failed": True, "time_s": summary.get("t_end_s"), "reason": summary.get("stop_reason")}
        else:
            r["failure"] = {"failed": False, "time_s": None, "reason": None}
        if x[NSAMP]:
            r["tether"] = {"max_tension_N": float(x[TMAX]), "slack_fraction": float(x[NSLACK] / x[NSAMP]),
                           "slack": bool(x[NSLACK] == x[NSAMP]), "slack_tension_N": p.slack_tension}
        return r

    @staticmethod
    def format_report(r: dict) -> list[str]:
        """Lines for the terminal."""
        c, h, d, f = r["contact"], r["hold"], r["vertical_distance"], r["failure"]
        lines = [f"contact: {'made at %.3g s' % c['time_s'] if c['made'] else 'never made'}",
                 f"hold: longest {h['longest_s']:.3g} s within {h['drift_tolerance_m'] * 1e3:.3g} mm "
                 f"({'achieved' if h['achieved'] else 'not achieved'}, {h['required_s']:.3g} s required)",
                 f"vertical distance from contact: up {d['up_m']:.3g} m, down {d['down_m']:.3g} m, "
                 f"net {d['net_m']:+.3g} m",
                 f"failure: {'at %.3g s: %s' % (f['time_s'], f['reason']) if f['failed'] else 'none'}"]
        if "tether" in r:
            tt = r["tether"]
            lines.append(f"tether: max tension after contact {tt['max_tension_N']:.3g} N, slack "
                         f"{100 * tt['slack_fraction']:.0f} % of the time")
        return lines
