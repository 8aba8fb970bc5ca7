"""A terrain as a triangle mesh for display: each kind draws itself (``Terrain.display_mesh``).

The built-in kinds' meshes, and the generic level-set mesh any other kind gets, are in
components/terrain/display.py (see its docstring for each kind); this module keeps the viewer's
names for them.
"""

from snakesim.components.terrain.base import TerrainMesh
from snakesim.components.terrain.display import (BLOCK_TONE, DEM_HIGH, DEM_LOW, ICE, MAX_DEM_SIDE, ROCK_TONE,
                                                 SPHERE_CHORD, level_set_mesh, terrain_mesh)

__all__ = ["TerrainMesh", "terrain_mesh", "level_set_mesh", "ICE", "DEM_LOW", "DEM_HIGH", "MAX_DEM_SIDE",
           "BLOCK_TONE", "ROCK_TONE", "SPHERE_CHORD"]
