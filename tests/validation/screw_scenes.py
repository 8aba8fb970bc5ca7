"""Screw-pair scenes on a plane of ice, built with the Python builder: eels-1.0 (2 modules, no head) on a
terrain, its screws held or spun by screw_drive's velocity servo (the other joints by its PD lock) and
touching through screw_sdf_contact. Shared by tests/contact/test_screw_sdf_scenes.py,
tests/contact/test_implicit_contact.py and bench/held_cases.py (its slope case)."""

from __future__ import annotations

import math

import numpy as np

from snakesim.components.contact.screw_sdf import ScrewSdfContact
from snakesim.components.control.screw_drive import ScrewDrive
from snakesim.components.multibody.component import Multibody
from snakesim.components.terrain.source import TerrainSource
from snakesim.framework import Builder

ROBOT = {"design": "eels-1.0", "modules": 2, "head": False}
SCREW_RADIUS = 0.0898          # m, the screws' contact radius: the base height that touches a plane


def plane(mu: float = 0.1, tilt: float | None = None) -> dict:
    """A plane of ice (k 1e5 N/m, c 1e3 N·s/m, friction μ), tilted by ``tilt`` rad (+x rising) if given."""
    spec = {"kind": "plane", "materials": [{"name": "ice", "k": 1.0e5, "c": 1.0e3, "mu": mu}]}
    return spec if tilt is None else {"kind": "plane", "tilt": tilt, "materials": spec["materials"]}


def on_slope(theta: float, r: float = SCREW_RADIUS) -> dict:
    """Base pose lying along the fall line (+x rises), axis tilted up by θ, screws touching."""
    n = np.array([-math.sin(theta), 0.0, math.cos(theta)])
    pos = r * n
    quat = [0.0, math.sin(-theta / 2), 0.0, math.cos(-theta / 2)]   # R_y(−θ): x̂ -> (cosθ, 0, sinθ)
    return {"base_position": [float(p) for p in pos], "base_quaternion": quat}


def downhill(com, theta: float):
    """Distance along the fall line of the slope θ (m) of positions ``com`` (n, 3)."""
    com = np.asarray(com)
    return -(com[:, 0] * math.cos(theta) + com[:, 2] * math.sin(theta))


def screw_scene(b: Builder, *, terrain: dict, robot: dict, omega: float = 0.0, contact: dict | None = None):
    """Add terrain, robot, drive and contact to ``b``, wired but for the contact's wrenches (the caller
    sends ``contact.out.wrenches`` to ``robot.inp.wrenches``, or on through its own blocks); returns
    (robot, contact)."""
    ground = b.add(TerrainSource("terrain", spec=terrain))
    body = b.add(Multibody("robot", **ROBOT, **robot))
    drive = b.add(ScrewDrive("drive", omega=omega))
    touch = b.add(ScrewSdfContact("contact", **(contact or {})))
    b.connect(ground.out.terrain, touch.inp.terrain)
    b.connect(body.out.link_poses, touch.inp.link_poses)
    b.connect(body.out.link_velocities, touch.inp.link_velocities)
    b.connect(body.out.joint_v, touch.inp.joint_v, drive.inp.joint_v)
    b.connect(body.out.joint_q, drive.inp.joint_q)
    b.connect(drive.out.tau, body.inp.tau)
    return body, touch


def held_on_slope(*, theta: float, mu: float, ev_a: float, duration: float, dt: float, integrator,
                  record_rate: float):
    """The screws held (ω = 0) on a slope θ below or above the friction angle, thread anisotropy ‖e_v‖ =
    ev_a; the centre of mass recorded. The built Simulation."""
    b = Builder(dt=dt, duration=duration, integrator=integrator, record_rate=record_rate)
    body, touch = screw_scene(b, terrain=plane(mu, tilt=theta), robot=on_slope(theta),
                              contact={"material": {"ev_a": ev_a}})
    b.connect(touch.out.wrenches, body.inp.wrenches)
    b.record(body.out.com)
    return b.build()
