"""Terrain library: one vectorised query (signed distance, normal, closest point,
material) over analytic shapes, obstacle fields, DEM height fields and imported meshes.

    from snakesim.components.terrain import load_terrain
    q = load_terrain("u-channel").query(points)     # points (n, 3)
"""

from .analytic import FourierCylinder, Moulin, ParallelWalls, PlaneTerrain, SlotMoulin, UChannel
from .base import Bounds, Material, Terrain, TerrainQuery
from .dem import HeightField, fractal_heights
from .mesh import SdfGrid, mesh_terrain
from .obstacles import Block, ObstacleField, Rock, scatter_obstacles
from .source import TerrainSource
from .spec import available_terrains, build_terrain, load_terrain, validate_spec

__all__ = ["Terrain", "TerrainQuery", "Material", "Bounds", "PlaneTerrain", "ParallelWalls", "UChannel",
           "FourierCylinder", "Moulin", "SlotMoulin", "ObstacleField", "Block", "Rock", "scatter_obstacles", "HeightField",
           "fractal_heights", "SdfGrid", "mesh_terrain",
           "TerrainSource", "load_terrain", "build_terrain", "validate_spec", "available_terrains"]
