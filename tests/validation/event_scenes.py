"""Event cases shared by the tests (tests/contact/test_contact_events.py) and bench/events.py: the default
scene's robot dropped onto the ice from a height, its screws idle, at any integrator setting, and what a
drop is judged by (the centre of mass never above its start, the rest pose against a converged RK4 run)."""

from __future__ import annotations

import numpy as np

from snakesim.framework.session import load_session

SCENE = "surface-screw-traverse"
REST_Z = 0.0898                   # m: the default scene's base height, its screw envelopes just pressing the ice
REFERENCE = {"name": "rk4", "params": {}}
REFERENCE_DT = 2e-4               # s: RK4 converged on these drops (0.1 ms moves the rest pose by < 0.05 mm)


def drop(height: float, integrator: dict | None = None, dt: float | None = None, duration: float = 1.0,
         sets=()):
    """The default robot released ``height`` m above its resting height, screws idle (the schedule's settle
    outlasts the run). ``integrator``/``dt`` None: the scene's own (what a user gets). Returns the run."""
    sim = {"duration": duration}
    if integrator is not None:
        sim["integrator"] = integrator
    if dt is not None:
        sim["dt"] = dt
    s = load_session(SCENE, overrides=[f"components.robot.params.base_position=[0,0,{REST_Z + height!r}]",
                                       f"settle={duration + 1.0!r}", *sets], sim_overrides=sim)
    return s.run()


def reference_drop(height: float, duration: float = 1.0):
    return drop(height, REFERENCE, REFERENCE_DT, duration)


def rise_above_start(r) -> float:
    """m: the largest height of the centre of mass above where it started (> 0: energy was injected)."""
    z = np.asarray(r["robot.com"])[:, 2]
    return float(z.max() - z[0])


def rest_offset(r, ref) -> float:
    """m: the largest distance between a link origin at the end of ``r`` and in the reference."""
    a = np.asarray(r["robot.link_poses"])[-1].reshape(-1, 7)[:, :3]
    b = np.asarray(ref["robot.link_poses"])[-1].reshape(-1, 7)[:, :3]
    return float(np.linalg.norm(a - b, axis=1).max())
