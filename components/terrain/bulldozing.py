"""Bulldozing of the deformable soil (its ``bulldozing:`` key): the soil a step presses out of the rut is heaped
on the contact patch's rim, then slides down to the angle of repose, so the rut's volume reappears as berms
beside it instead of vanishing (compaction). The heuristic of Chrono's SCM (``SCMTerrain::EnableBulldozing``,
``SetBulldozingParameters(erosion_angle, flow_factor, erosion_iterations, erosion_propagations)``; Krenn &
Hirzinger 2009):

    bulldozing: {erosion_angle: 35.0, flow_factor: 1.0, erosion_iterations: 5}

- per contact patch (a screw, a body cylinder), the volume its commit pressed out, V = Σ Δs_p Δ² (the plastic
  sinkage's growth, vertical, times the cell's area), is spread evenly over the rim: the patch's nodes'
  4-neighbours that are not in contact; ``flow_factor`` V of it (1: the soil is incompressible and its volume
  is kept; 0: all compaction, as without bulldozing);
- erosion, ``erosion_iterations`` passes: between a rim (or already reached) node and a neighbour out of
  contact whose relief differs by more than Δ tan(erosion_angle), half the excess moves down; the receiving
  node joins, so the heap spreads a ring a pass. Soil moves between nodes, never out of them: the volume is
  conserved to rounding.
- soil put on a node refills its rut first, then raises the node's virgin level (``lift``, SCM's
  level_initial), and is loose (the node's yield memory cleared): a body pressing a berm meets the soil law
  from its top, and the volume it presses out is heaped on again; soil taken off a node comes from its heap
  first, then deepens its rut.

Relief is measured on the base (the plastic sinkage alone), so the slopes of a DEM base never erode. The
kernels are bulldozing_kernels.py; ``SoilFlowLog`` is a contact's per-run buffer (the commit's log, the marks).
Not modelled: bulldozing by the rigid wheel (wheel.py), soil carried by a moving body (SCM's neither).
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from .bulldozing_kernels import bulldoze
from .spec_models import open_quadrant_deg


class BulldozingSpec(BaseModel):
    """The bulldozing heuristic's parameters (module docstring; SCM's names)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    erosion_angle: float = Field(35.0, description="deg, the angle of repose the berms erode to, in (0, 90)")
    flow_factor: float = Field(1.0, ge=0, le=1, description="fraction of the pressed-out volume heaped on the rim "
                                                            "(1: incompressible, the volume kept; 0: all compacted)")
    erosion_iterations: int = Field(5, ge=0, description="erosion passes per step (each spreads the heap a ring)")

    @field_validator("erosion_angle")
    @classmethod
    def _angle(cls, v):
        return open_quadrant_deg(v, "erosion_angle", " (the soil's angle of repose)")


class SoilFlowLog:
    """One contact's bulldozing buffers for a run (none when the terrain does not bulldoze): the commit's log
    of up to ``rows`` contact nodes (the contact kernels write it, ``entries`` and ``count``), the marks and
    the rim's queue. ``apply`` heaps and erodes after a commit."""

    def __init__(self, terrain, rows: int):
        self.spec = getattr(terrain, "bulldozing", None)
        on = self.spec is not None
        self.entries = np.zeros((rows if on else 0, 4))
        self.count = np.zeros(2, dtype=np.int64)
        self.mark = np.zeros(terrain.state.plastic.shape if on else (0, 0, 0), dtype=np.int8)
        self.queue = np.zeros((8 * rows + 4096 if on else 0, 2), dtype=np.int64)

    def apply(self, terrain) -> int:
        """Heap and erode the logged commit; the rim nodes raised (0 without bulldozing), −1 when the terrain's
        tile pool ran out."""
        if self.spec is None or self.count[0] == 0:
            self.count[0] = 0
            return 0
        s, st = self.spec, terrain.state
        return int(bulldoze(terrain.grid, st.tile_of, st.plastic, st.yield_p, st.lift, st.used, self.entries,
                            self.count,
                            self.mark, self.queue, s.flow_factor, math.tan(math.radians(s.erosion_angle)),
                            s.erosion_iterations))
