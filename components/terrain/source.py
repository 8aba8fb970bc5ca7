"""Terrain source: loads a terrain once and offers it to contact models.

params  name   terrain name in terrains/ or a path (YAML or OBJ/STL/PLY)
        spec   inline definition (a terrain YAML mapping); overrides name
        store  terrain-store folder for mesh SDF grids (default: see store.py)
out     terrain  structured Terrain (no inputs, no state): the same object every step; a deformable
                 kind changes its ``terrain.state`` in place (terrain/base.py), so consumers bound to
                 the object never rebind during a run
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from snakesim.framework import Component, Output, Params
from snakesim.framework.paths import assembly_path

from .base import Terrain
from .spec import load_terrain


def looks_like_a_path(name: str) -> bool:
    """A file, not a name in terrains/: it has a folder or a file suffix."""
    return "/" in name or name.lower().endswith((".yaml", ".yml", ".obj", ".stl", ".ply"))


class TerrainSourceParams(Params):
    name: Annotated[str, assembly_path(looks_like_a_path)] = Field(
        "flat-ice", description="terrain name in terrains/, or a path (relative to the file naming it)")
    spec: dict | None = Field(None, description="inline terrain definition")
    store: str | None = Field(None, description="terrain store folder")


class TerrainSource(Component[TerrainSourceParams]):
    type_name = "terrain"
    time_invariant = True  # loaded once; the same object every step
    terrain = Output(type=Terrain, feedthrough=(), doc="the terrain query object")

    def setup(self):
        p = self.p
        self._terrain = load_terrain(p.spec if p.spec is not None else p.name, store=p.store)

    def output(self, t, x, u, y):
        y.terrain = self._terrain
