"""A HelicalGait made on a robot model without a build (its setup() run), for the gait's own tests."""

from __future__ import annotations

from snakesim.components.control.helical_gait import HelicalGait


def make_gait(robot, **params) -> HelicalGait:
    c = HelicalGait.__new__(HelicalGait)
    c.name, c.robot, c.p = "gait", robot, HelicalGait.Params(**params)
    c.setup()
    return c
