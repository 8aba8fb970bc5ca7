"""The scene's terrain as coal geometry (built once per Terrain object).

Each kind says what its geometry is (``Terrain.contact_parts``: half-spaces and triangle
sets; components/terrain/contact_geometry.py for the built-in kinds, the display mesh's
triangles for any other): a HalfSpace becomes a coal.Halfspace (exact; coal's half-space
{x: n·x ≤ d} is the solid), a Triangles set a coal BVHModelOBBRSS surface (coal tests a
convex piece against each nearby triangle). Triangles have no inside, so the component
orients their contact normals with the terrain's own query normal (Terrain.query is the
source of truth for which side is solid). Moulins and obstacle fields are not supported
yet (a shaft through a plane has no convex part and needs a holed surface mesh).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from snakesim.components.terrain.contact_geometry import grid_triangles  # noqa: F401  (re-exported)


@dataclasses.dataclass
class TerrainPart:
    geom: object          # coal geometry
    transform: object     # coal.Transform3s (world pose of the geometry)
    triangles: bool       # a triangle BVH (normals need orienting, several contacts per piece)


SUPPORTED = ("plane", "parallel_walls", "u_channel", "tube", "dem", "mesh")


def _halfspace(normal, offset):
    import coal

    return TerrainPart(coal.Halfspace(np.asarray(normal, float), float(offset)), coal.Transform3s(), False)


def _bvh(vertices, faces):
    import coal

    bvh = coal.BVHModelOBBRSS()
    bvh.beginModel(len(faces), len(vertices))
    bvh.addVertices(np.ascontiguousarray(vertices, dtype=np.float64))
    bvh.addTriangles(np.ascontiguousarray(faces, dtype=np.int64))
    bvh.endModel()
    return TerrainPart(bvh, coal.Transform3s(), True)


def terrain_parts(terrain, extent: float = 10.0, segments: int = 64, resolution: float = 0.05) -> list[TerrainPart]:
    """coal parts of ``terrain`` (its kind's ``contact_parts``); ValueError for a kind without them."""
    from snakesim.components.terrain.base import HalfSpace

    t = terrain
    try:
        parts = t.contact_parts(extent, segments, resolution)
    except NotImplementedError:
        raise ValueError(f"hull_contact: terrain kind '{t.kind}' ({t.name}) has no coal representation; "
                         f"supported kinds: {', '.join(SUPPORTED)} and any kind that meshes its surface "
                         f"(use the SDF back end for it)") from None
    return [_halfspace(p.normal, p.offset) if isinstance(p, HalfSpace) else _bvh(p.vertices, p.faces)
            for p in parts]
