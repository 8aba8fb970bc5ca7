"""What a sensor can see: the physical surfaces as triangles with optical properties.

Built from the same geometry the viewer logs under ``world/physical`` (paper 2.2.3:
ornamental geometry never occludes a sensor):

    TerrainSurfaces   the terrain's display mesh (its kind's ``display_mesh``), uncut (no
                      cut-away), world frame, built once;
                      per face the albedo and colour of the terrain material at its centroid
    RobotSurfaces     every link's URDF visual mesh in its link frame, packed once per robot;
                      per face the albedo and colour of the link's URDF material colour
                      (albedo = mean of the linear RGB, unless the scene gives one)

Units m; colours linear RGB in [0, 1]. Tethers are not visible (thin ropes: a lidar
return from a 1 cm rope at 10 m is below any beam's footprint; left out on purpose).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numba import njit

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.terrain import Terrain


@dataclasses.dataclass(frozen=True)
class TerrainSurfaces:
    """vertices (n, 3) m world, faces (m, 3) int32, material (m,) index into terrain.materials,
    albedo (m,), color (m, 3); ``refine`` (m,)
    marks the faces that only approximate a curved analytic surface (their centroid is off the
    surface by the tessellation's sag): the caster refines hits on them onto the true surface."""

    terrain: Terrain
    vertices: np.ndarray
    faces: np.ndarray
    material: np.ndarray
    albedo: np.ndarray
    color: np.ndarray
    refine: np.ndarray


@dataclasses.dataclass(frozen=True)
class RobotSurfaces:
    """All link meshes packed: vertices (n, 3) m in their link frames, ``vertex_link`` (n,) the
    link row (RobotModel.links order, the ``link_poses`` rows) of each vertex, faces (m, 3) int32,
    ``face_link`` (m,), albedo (m,), color (m, 3)."""

    vertices: np.ndarray
    vertex_link: np.ndarray
    faces: np.ndarray
    face_link: np.ndarray
    albedo: np.ndarray
    color: np.ndarray

    def posed(self, rotations: np.ndarray, positions: np.ndarray) -> np.ndarray:
        """World vertices (n, 3) for link rotations (nl, 3, 3) and origins (nl, 3)."""
        out = np.empty(self.vertices.shape)
        pose_vertices(self.vertex_link, self.vertices, np.ascontiguousarray(rotations, dtype=np.float64),
                      np.ascontiguousarray(positions, dtype=np.float64), out)
        return out


@njit(cache=True, nogil=True)
def pose_vertices(link, vertices, rotations, positions, out):
    """out[k] = R_l·v_k + p_l, l = link[k] (compiled: NumPy's einsum over the gathered rotations took
    ~1.3 ms for EELS 1.0's 24k vertices, this ~0.1 ms). R_l·v summed as x + z, then + y: the order of
    the einsum it replaces, so posed meshes (and the images rasterised from them) are unchanged bit
    for bit."""
    for k in range(vertices.shape[0]):
        l = link[k]
        x, y, z = vertices[k, 0], vertices[k, 1], vertices[k, 2]
        for a in range(3):
            out[k, a] = (rotations[l, a, 0] * x + rotations[l, a, 2] * z + rotations[l, a, 1] * y) + positions[l, a]


def terrain_surfaces(terrain: Terrain, center=(0.0, 0.0, 0.0), extent: float = 30.0,
                     cell: float = 0.1, refine: bool = True) -> TerrainSurfaces:
    """The terrain as a sensor sees it: its display mesh with nothing cut away, ``extent`` (m)
    around ``center`` for unbounded kinds, curved kinds tessellated at ``cell`` (m) and, with
    ``refine``, their hits refined onto the exact surface."""
    from snakesim.components.terrain.display import terrain_mesh

    cell = terrain.sensor_cell(extent, cell)      # flat ground tessellates exactly: a few large quads
    mesh = terrain_mesh(terrain, center=center, extent=extent, cell=cell, cutaway=None)
    V = np.asarray(mesh.vertices, dtype=np.float64)
    F = np.asarray(mesh.faces, dtype=np.int32)
    at_centroid = terrain.query(V[F].mean(axis=1))
    albedo, color = optical_table(terrain.materials)
    m = at_centroid.material
    # a flat face lies on the surface to float32 rounding of its vertices (≈1e-7 relative)
    off = np.abs(at_centroid.distance) > SAG_TOL * np.maximum(1.0, np.abs(V[F[:, 0]]).max(axis=1))
    # a kind whose surface can rise above its mesh where a ray passes over it (a DEM's bilinear cells)
    # refines the hits on every face: the first crossing may lie before a flat face's hit
    off |= bool(terrain.refine_every_face)
    return TerrainSurfaces(terrain, V, F, m, albedo[m], color[m], refine=off & (refine and is_exact(terrain)))


#: a face whose centroid is farther than this (relative) from the surface approximates a curve
SAG_TOL = 1e-6


def optical_table(materials) -> tuple[np.ndarray, np.ndarray]:
    """(albedo (k,), color (k, 3)) of k materials, in order."""
    return (np.array([m.albedo for m in materials], dtype=np.float64),
            np.array([m.color for m in materials], dtype=np.float64).reshape(-1, 3))


def is_exact(terrain: Terrain) -> bool:
    """Whether the terrain's zero level set is its true surface and its display mesh only a
    tessellation of it (the kind's ``refine_hits``: refine mesh hits onto the surface). A mesh
    terrain's mesh is the imported file (its distance grid is the approximation): casting against
    the mesh is exact for it. A height field's mesh is its grid in triangles, its surface the grid's
    bilinear interpolation: its hits are refined (refine_kernels.DemRefiner)."""
    return bool(terrain.refine_hits)


def robot_surfaces(robot: RobotModel, albedo: float | None = None, geometry: str = "visual") -> RobotSurfaces:
    """Pack ``robot``'s link meshes: ``visual`` (the URDF visuals, shared with the viewer:
    ``robot.derived(link_meshes)``) or ``collision`` (the contact shapes: a screw's envelope
    cylinder instead of its 1000-triangle blades; each link coloured as its first visual)."""
    from snakesim.components.viz.robot_geometry import link_collision_meshes, link_meshes

    meshes = robot.derived(link_meshes)
    if geometry == "collision":
        colour = {m.link: m.colors[0] for m in meshes}
        meshes = [dataclasses.replace(m, colors=np.tile(colour[m.link], (len(m.vertices), 1)))
                  if m.link in colour else m for m in robot.derived(link_collision_meshes)]
    if not meshes:
        z = np.zeros((0, 3))
        return RobotSurfaces(z, np.zeros(0, np.int64), np.zeros((0, 3), np.int32), np.zeros(0, np.int64),
                             np.zeros(0), z)
    rows = [robot.link_index(m.link) for m in meshes]
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    faces = np.vstack([m.faces.astype(np.int64) + o for m, o in zip(meshes, offsets)]).astype(np.int32)
    # a face's colour is its first vertex's (visual parts are coloured per part, not per vertex)
    rgb = np.vstack([m.colors[:, :3] for m in meshes])[faces[:, 0]].astype(np.float64) / 255.0
    return RobotSurfaces(
        vertices=np.vstack([m.vertices for m in meshes]).astype(np.float64),
        vertex_link=np.concatenate([np.full(len(m.vertices), r) for m, r in zip(meshes, rows)]),
        faces=faces,
        face_link=np.concatenate([np.full(len(m.faces), r) for m, r in zip(meshes, rows)]),
        albedo=rgb.mean(axis=1) if albedo is None else np.full(len(faces), float(albedo)),
        color=rgb,
    )
