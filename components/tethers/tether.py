"""Tethers: stiff spring-damper ropes from robot points to fixed world anchors (paper 2.2.6).

Tether j runs from point p_j = o + R·offset_j on its link (o the link origin,
R its axes) to the world anchor A_j. With d = A_j − p_j, ℓ = |d|, e = d/ℓ::

    ℓ̇ = −e · ṗ_j,         ṗ_j = v_o + ω × (R·offset_j)
    T  = max(0, k (ℓ − ℓ0) + c ℓ̇)   if ℓ > ℓ0 and attached, else 0   (a rope: slack when
                                     compressed, and it never pushes, even while shortening fast)
    F  = T e  on the robot at p_j;   about the link origin: τ = (R·offset_j) × F

Wrenches of every tether are summed per link: ``wrenches[nl, 6]`` is in the
multibody's convention ([f, τ], world axes, τ about each link origin). Feed
it to ``multibody.wrenches`` directly, or through ``wrench_sum`` with contact.

Attachment: each tether is attached for attach <= t < release (params); a
connected ``attached[n]`` input overrides element-wise where it is not NaN
(> 0.5 attached), so a schedule or an autonomy command can rig and release.

in   link_rotations[nl, 3, 3], link_poses[nl, 7], link_velocities[nl, 6]   from the multibody
     attached[n]   0/1 per tether (default NaN: the params' schedule)
out  wrenches[nl, 6]  N, N·m    (feedthrough)
     tension[n]  N,  length[n]  m
uses robot: RobotModel (the multibody's): link names and rows
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import ConfigDict, Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.framework import Component, Input, Output, Params, Uses

Vec3 = tuple[float, float, float]


class TetherSpec(Params):
    model_config = ConfigDict(frozen=True, extra="forbid")
    link: str = Field(..., description="robot link the rope is tied to")
    offset: Vec3 = Field((0.0, 0.0, 0.0), description="m, tie point in the link frame")
    anchor: Vec3 = Field(..., description="m, fixed world point")
    stiffness: float = Field(1.0e4, gt=0, description="N/m")
    damping: float = Field(100.0, ge=0, description="N·s/m, on the stretch rate")
    rest_length: float = Field(..., ge=0, description="m, unstretched length")
    attach: float = Field(0.0, description="s, attached from")
    release: float | None = Field(None, description="s, released at (None: never)")


class TetherParams(Params):
    tethers: list[TetherSpec] = Field(..., min_length=1)


def _nl6(c):
    return (c.robot.nl, 6)


def _n(c):
    return (len(c.p.tethers),)


class Tethers(Component[TetherParams]):
    type_name = "tethers"
    robot = Uses(RobotModel)

    link_rotations = Input(shape=link_shape(3, 3), unit="1")
    link_poses = Input(shape=link_shape(7), unit=None)
    link_velocities = Input(shape=_nl6, unit=None)
    attached = Input(shape=_n, unit="1", default=np.nan)
    wrenches = Output(shape=_nl6, unit=None, feedthrough=("link_rotations", "link_poses", "link_velocities",
                                                          "attached"))
    tension = Output(shape=_n, unit="N", feedthrough=True)
    length = Output(shape=_n, unit="m", feedthrough=True)

    def setup(self):
        links = self.robot.links
        ts = self.p.tethers
        bad = [t.link for t in ts if t.link not in links]
        if bad:
            raise ValueError(f"{self.name}: tether link(s) {bad} not in the robot; links: {', '.join(links)}")
        for j, t in enumerate(ts):
            if not all(math.isfinite(v) for v in (*t.offset, *t.anchor, t.attach)):
                raise ValueError(f"{self.name}: tethers[{j}]: offset, anchor and attach must be finite")
            if t.release is not None and not t.release > t.attach:
                raise ValueError(f"{self.name}: tethers[{j}]: release {t.release:g} s must come after attach {t.attach:g} s")
        self._li = np.array([self.robot.link_index(t.link) for t in ts], dtype=np.int64)
        self._r = np.array([t.offset for t in ts], dtype=float)
        self._A = np.array([t.anchor for t in ts], dtype=float)
        self._k = np.array([t.stiffness for t in ts])
        self._c = np.array([t.damping for t in ts])
        self._l0 = np.array([t.rest_length for t in ts])
        self._on = np.array([t.attach for t in ts])
        self._off = np.array([np.inf if t.release is None else t.release for t in ts])

    def output(self, t, x, u, y):
        li = self._li
        R = u.link_rotations[li]
        r = np.einsum("nij,nj->ni", R, self._r)                   # tie point from its link origin, world
        p = u.link_poses[li, :3] + r
        pdot = u.link_velocities[li, :3] + np.cross(u.link_velocities[li, 3:], r)
        d = self._A - p
        ell = np.sqrt((d * d).sum(axis=1))
        e = d / np.where(ell > 0, ell, 1.0)[:, None]
        ldot = -(e * pdot).sum(axis=1)
        cmd = u.attached
        on = np.where(np.isnan(cmd), (t >= self._on) & (t < self._off), cmd > 0.5)
        T = np.where(on & (ell > self._l0), np.maximum(0.0, self._k * (ell - self._l0) + self._c * ldot), 0.0)
        F = T[:, None] * e
        W = y.wrenches
        W[:] = 0.0
        np.add.at(W[:, :3], li, F)
        np.add.at(W[:, 3:], li, np.cross(r, F))
        y.tension[:] = T
        y.length[:] = ell
