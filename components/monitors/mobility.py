"""Mobility monitor for climbing tests (paper 4.3.1): failure detection and the test's metrics.

Tilt (the paper's "angle between the pitch of the body and the gravity
vector"), defined precisely: for each monitored link j, â_j = R_j·axis/|axis|
(default axis x: the robot axis, tail to head) and û = −g/|g| (up)::

    vertical "up":   θ_j = arccos(â_j · û)        head-up climbing: 0 when pointing straight up
    vertical "down": θ_j = arccos(−â_j · û)       head-first descent
    vertical "line": θ_j = arccos(|â_j · û|)      either way along the shaft, θ in [0, π/2] (default)

A mobility failure is max_j θ_j > max_tilt (default 60°): the body has
pitched away from the shaft's vertical by more than that, judged
irrecoverable; the run stops (``stop_on_failure``) with the link and angle.
In a horizontal surface traverse θ is ~90°: do not use this monitor there.

Metrics (the paper's integration test: contact, static hold, distance):
    contact_made   1 once the ``contacts`` input (a contact count) has been >= 1; t_contact its time
    hold_time      s, how long every link origin in ``hold_links`` has stayed below ``hold_speed``
                   (current stretch); max_hold_time the longest stretch so far
    climb          m, (p_ref(t) − p_ref(t0)) · û of ``reference_link``'s origin (negative going down);
                   max_climb the most so far
Discrete (needs a ``rate``): metrics advance once per sample of period T;
the outputs show the state up to the previous sample plus this sample's
instantaneous tilt, failure and climb.

in   link_rotations[nl, 3, 3], link_poses[nl, 7], link_velocities[nl, 6]   from the multibody
     contacts   contact count (optional; NaN/unconnected: contact_made stays 0)
out  tilt[nt] rad, max_tilt rad, failed, contact_made, t_contact s, hold_time s, max_hold_time s,
     climb m, max_climb m
uses robot: RobotModel (the multibody's): link names and rows
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.components.control.joint_selection import match
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.framework import Component, Input, Output, Params, Uses

from .tilt import TiltRule
from .watch import contact_hold_outputs

Vec3 = tuple[float, float, float]

# discrete state layout
STARTED, P0, CONTACT, T_CONTACT, HOLD, MAX_HOLD, MAX_CLIMB, FAILED = 0, 1, 2, 3, 4, 5, 6, 7


class MobilityParams(Params):
    tilt_links: list[str] = Field(default_factory=lambda: ["module_*"], description="links whose axis is checked")
    axis: Vec3 = Field((1.0, 0.0, 0.0), description="body axis in each link frame")
    vertical: Literal["up", "down", "line"] = "line"
    max_tilt: float = Field(math.radians(60.0), gt=0, le=math.pi, description="rad")
    stop_on_failure: bool = True
    gravity: Vec3 = Field((0.0, 0.0, -9.81), description="direction of gravity, world (magnitude unused)")
    hold_links: list[str] = Field(default_factory=lambda: ["*"], description="links that must be still to hold")
    hold_speed: float = Field(0.01, gt=0, description="m/s, link-origin speed below which a link is still")
    reference_link: str | None = Field(None, description="link whose climb is measured (default: the root)")


class MobilityMonitor(Component[MobilityParams]):
    type_name = "mobility_monitor"
    robot = Uses(RobotModel)

    link_rotations = Input(shape=link_shape(3, 3), unit="1")
    link_poses = Input(shape=link_shape(7), unit=None)
    link_velocities = Input(shape=link_shape(6), unit=None)
    contacts = Input(shape=(1,), unit=None, default=np.nan)
    tilt = Output(shape=lambda c: (len(c.tilt_names),), unit="rad", names=lambda c: c.tilt_names)
    max_tilt = Output(shape=(), unit="rad")
    failed = Output(shape=(), unit="1")
    contact_made, t_contact, hold_time, max_hold_time = contact_hold_outputs()
    climb = Output(shape=(), unit="m")
    max_climb = Output(shape=(), unit="m")

    def setup(self):
        p = self.p
        links = list(self.robot.links)
        self._tilt = TiltRule(self.name, links, p)
        self._up, self.tilt_names = self._tilt.up, self._tilt.names
        self._hold_i = np.array(sorted({i for pat in p.hold_links for i in match(links, pat, f"{self.name}: hold_links")}),
                                dtype=np.int64)
        ref = p.reference_link if p.reference_link is not None else links[0]
        if ref not in links:
            raise ValueError(f"{self.name}: reference_link '{ref}' is not a link; links: {', '.join(links)}")
        self._ref = links.index(ref)

    def discrete_state(self):
        return np.zeros(8)          # t_contact is read only once contact_made is 1 (state must stay finite)

    def _tilts(self, u) -> np.ndarray:
        return self._tilt.angles(u.link_rotations[self._tilt.rows] @ self._tilt.axis)

    def _climb(self, x, u) -> float:
        if x[STARTED] == 0.0:
            return 0.0
        return float(u.link_poses[self._ref, :3] @ self._up - x[P0])

    def output(self, t, x, u, y):
        tilt = self._tilts(u)
        y.tilt[:] = tilt
        worst = float(tilt.max()) if tilt.size else 0.0
        y.max_tilt[...] = worst
        fail = worst > self.p.max_tilt
        y.failed[...] = float(fail or x[FAILED] > 0)
        if fail and self.p.stop_on_failure:
            self.stop(self._tilt.failure(tilt, worst), kind="mobility")
        y.contact_made[...] = x[CONTACT]
        y.t_contact[...] = x[T_CONTACT] if x[CONTACT] else np.nan
        y.hold_time[...] = x[HOLD]
        y.max_hold_time[...] = x[MAX_HOLD]
        climb = self._climb(x, u)
        y.climb[...] = climb
        y.max_climb[...] = max(climb, x[MAX_CLIMB])

    def update(self, t, xd, u):
        T = 1.0 / self.rate
        if xd[STARTED] == 0.0:
            xd[P0] = u.link_poses[self._ref, :3] @ self._up
            xd[STARTED] = 1.0
        xd[MAX_CLIMB] = max(xd[MAX_CLIMB], self._climb(xd, u))
        n = float(u.contacts[0])
        if xd[CONTACT] == 0.0 and n == n and n >= 1:
            xd[CONTACT], xd[T_CONTACT] = 1.0, t
        v = u.link_velocities[self._hold_i, :3]
        still = bool(((v * v).sum(axis=1) < self.p.hold_speed ** 2).all())
        xd[HOLD] = xd[HOLD] + T if still else 0.0
        xd[MAX_HOLD] = max(xd[MAX_HOLD], xd[HOLD])
        if self._tilts(u).max(initial=0.0) > self.p.max_tilt:
            xd[FAILED] = 1.0
