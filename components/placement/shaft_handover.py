"""Hand a ``shaft_brace`` placement over to brace_climb (issue 30): the controller and the wall loads it regulates
take the placement's numbers, not hand-typed ones.

    brace:      {type: shaft_brace_climb, rate: 100, params: {shaft: *shaft, target_fraction: 0.8, ...}}
    wall_loads: {type: shaft_wall_loads, params: {shaft: *shaft}}

``shaft`` is the robot's ``shape`` (a YAML anchor keeps them one mapping); both read the memoised placement
(shaft_brace.place_in_shaft: one survey and fit per process) in ``setup()`` and write what they derive into
their parameters, so config.yaml shows it:

shaft_brace_climb   brace_climb with base = the placed q (rad), torque_pattern = its gravity pre-load (N·m at
                    A = 1, bend and twist joints), load_screws = the bracing screws, climb_signs = +1/−1 by
                    wall (0 free), and with ``target_fraction`` f, target = f·min_k N_k (N)
shaft_wall_loads    fts_wall_loads along the surveyed walls' mean normal n̂ (world, unit): |F_k·n̂| per segment
"""

from __future__ import annotations

from pydantic import Field

from snakesim.components.control.brace_climb import BraceClimb, BraceClimbParams
from snakesim.components.sensors.fts_wall_loads import FtsWallLoads, FtsWallLoadsParams

from .shaft_brace import ShaftBrace, place_in_shaft


class ShaftBraceClimbParams(BraceClimbParams):
    shaft: ShaftBrace = Field(description="the robot's shaft_brace shape: the placement this controller holds")
    target_fraction: float | None = Field(None, gt=0, description="target = this × the least bracing load at "
                                          "A = 1 (None: the target parameter)")


class ShaftBraceClimb(BraceClimb):
    """brace_climb holding a ``shaft_brace`` placement (module docstring); everything else is brace_climb's."""

    type_name = "shaft_brace_climb"
    Params = ShaftBraceClimbParams

    def setup(self):
        p = self.p
        pl = place_in_shaft(self.robot, p.shaft)
        update = {"base": pl.q, "torque_pattern": pl.torque_pattern(self.robot), "pattern": {},
                  "load_screws": sorted(pl.loads), "climb_signs": pl.wall_sign}
        if p.target_fraction is not None:
            update["target"] = p.target_fraction * min(pl.loads.values())
        self.p = p.model_copy(update=update)
        super().setup()


class ShaftWallLoadsParams(FtsWallLoadsParams):
    shaft: ShaftBrace = Field(description="the robot's shaft_brace shape: its survey's wall normal")


class ShaftWallLoads(FtsWallLoads):
    """fts_wall_loads along the placement's surveyed wall normal (module docstring)."""

    type_name = "shaft_wall_loads"
    Params = ShaftWallLoadsParams

    def setup(self):
        n = place_in_shaft(self.robot, self.p.shaft).survey.normal
        self.p = self.p.model_copy(update={"component": "along_normal", "normal": tuple(float(v) for v in n)})
        super().setup()
