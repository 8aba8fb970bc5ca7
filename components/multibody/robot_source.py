"""Which robot: the parameters every robot-facing component shares.

The multibody, contact back ends, controllers, sensors, tethers and placement
all take these same keys, so an assembly passes the robot once (a scene
parameter ``robot``) and every component resolves the same cached URDF
layout: link and joint orders agree by construction.
"""

from __future__ import annotations

from typing import Any

from pydantic import Field

from snakesim.framework import Params


class RobotSource(Params):
    urdf: str | None = Field(None, description="URDF text or path; with 'design', a user URDF of that design "
                                               "(checked against its structure)")
    design: str | None = Field(None, description="snakesim.robots design, e.g. eels-1.0")
    modules: int | None = Field(None, ge=1, description="module count for a design")
    head: bool | None = Field(None, description="head on/off for a design (default: the design's)")
    robot: dict[str, Any] = Field(default_factory=dict, description="generator parameters (hand, lead_angle, ...)")
