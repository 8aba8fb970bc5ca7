"""Terrain library: one vectorised query (signed distance, normal, closest point,
material) over analytic shapes, obstacle fields, DEM height fields and imported meshes.

    from snakesim.components.terrain import load_terrain
    q = load_terrain("u-channel").query(points)     # points (n, 3)

A kind is a Terrain subclass registered as a TerrainKind (kinds.py) through the plugin hook
``snakesim_register_terrain_kinds``; built-in kinds register exactly as a plugin's do.
"""

from .analytic import FourierCylinder, Moulin, ParallelWalls, PlaneTerrain, SlotMoulin, UChannel
from .base import Bounds, HalfSpace, Material, Terrain, TerrainMesh, TerrainQuery, TerrainState, Triangles
from .dem import HeightField, fractal_heights
from .derived import TerrainDerived
from .mesh import SdfGrid, mesh_terrain
from .obstacles import Block, ObstacleField, Rock, scatter_obstacles
from .kinds import BuildContext, TerrainKind, terrain_kinds
from .source import TerrainSource
from .spec import KindSpec, available_terrains, build_terrain, load_terrain, validate_spec

__all__ = ["Terrain", "TerrainQuery", "TerrainState", "TerrainDerived", "TerrainMesh", "HalfSpace", "Triangles", "TerrainKind",
           "BuildContext", "KindSpec", "terrain_kinds", "Material", "Bounds", "PlaneTerrain", "ParallelWalls", "UChannel",
           "FourierCylinder", "Moulin", "SlotMoulin", "ObstacleField", "Block", "Rock", "scatter_obstacles", "HeightField",
           "fractal_heights", "SdfGrid", "mesh_terrain",
           "TerrainSource", "load_terrain", "build_terrain", "validate_spec", "available_terrains"]
