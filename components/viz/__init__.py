"""Visualisation: a rerun viewer sink, ``snakesim run --viz`` and ``snakesim replay``.

- :mod:`.sink`: the ``rerun_viewer`` component (live viewer or .rrd file)
- :mod:`.attach`: what ``--viz`` adds to a scene
- :mod:`.replay`: an ``--out`` folder to an .rrd, no re-simulation
- :mod:`.entities`: the entity layout and the physical / ornamental contract
- :mod:`.robot_geometry`, :mod:`.terrain_geometry`: meshes from URDF visuals and terrain parameters
"""

from .entities import is_physical
from .sink import RerunSink, RerunSinkParams
from .target import VizTarget, parse_target

__all__ = ["RerunSink", "RerunSinkParams", "VizTarget", "parse_target", "is_physical"]
