"""Robot placement (paper 2.2.6): shape guesses fitted to joint angles, then settling into the terrain.

shapes.py           the shape guesses (curves) and their world pose
fit.py              fit_shape(): curve -> q0 + tail pose for a design
placed_multibody.py component `placed_multibody`: the multibody with a `shape:` parameter
settle.py           component `placement_settle`: attraction, settle test, latch, gravity on; its phases
                    (SettlePhase) and the attraction springs it shows (AttractionSet)
handoff.py          a settled placement's state as a hold run's parameters
shaft_survey.py     survey_shaft(): a shaft's narrow axis, walls, width and roughness at a point, by rays
shaft_brace.py      shape kind `shaft_brace`: survey, fit, refine against the terrain, pre-load
shaft_handover.py   components `shaft_brace_climb`, `shaft_wall_loads`: brace_climb and its wall loads from that placement
"""

from .fit import Placement, PlacementError, fit_shape
from .placed_multibody import PlacedMultibody
from .settle import AttractionSet, Settle, SettlePhase
from .shaft_brace import ShaftBrace
from .shaft_handover import ShaftBraceClimb, ShaftWallLoads
from .shapes import Pose, Shape

__all__ = ["AttractionSet", "PlacedMultibody", "Placement", "PlacementError", "Pose", "Settle", "SettlePhase",
           "ShaftBrace", "ShaftBraceClimb", "ShaftWallLoads", "Shape", "fit_shape"]

#: the components this package registers (components/plugin.py BUILTIN)
PLACEMENT = (PlacedMultibody, Settle, ShaftBraceClimb, ShaftWallLoads)
