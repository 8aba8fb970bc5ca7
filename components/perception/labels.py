"""Ground-truth labels: what each lidar beam and camera pixel hit, as one unsigned integer.

    0                 NOTHING    no surface within range (a miss; a lidar beam too close or lost
                                 still carries the label of the surface it met)
    1 + m             TERRAIN    terrain of material m (``terrain.materials`` order: the kind's
                                 regions through its ``region_material``), m < 999
    1000 + row        ROBOT      robot link ``row`` (RobotModel.links order, the ``link_poses``
                                 rows), row < 1000
    2000 + i          OBSTACLE   part i of a terrain with parts (Terrain.parts): an ``obstacles``
                                 terrain's blocks in the order given, then its rocks (block b:
                                 2000 + b; rock k: 2000 + nb + k); its ground keeps its TERRAIN label

Stored as uint16 (``LABEL_DTYPE``: LidarScan.label, CameraFrame.label, a PointCloud2's ``label``
field, the ``mono16`` label image). ``label_name`` turns a label back into words.

The cast knows what a ray hit from Embree: a robot hit's link row (its scene is the link's), a
terrain hit's face (primID), whose material the cast keeps (after refinement onto the exact
surface) and whose part ``terrain_face_labels`` finds once per terrain scene from the face's
centroid (``Terrain.parts``: an obstacle field's ground is no part, each block and rock is one).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

LABEL_DTYPE = np.uint16
NOTHING = 0
TERRAIN = 1
ROBOT = 1000
OBSTACLE = 2000
MAX_MATERIALS = ROBOT - TERRAIN
MAX_LINKS = OBSTACLE - ROBOT
MAX_OBSTACLES = int(np.iinfo(LABEL_DTYPE).max) - OBSTACLE + 1


def label_name(label: int, terrain=None, links=None) -> str:
    """Words for a label: 'nothing', 'terrain:<material>', 'link:<name>', 'obstacle:<i>' (names from the
    terrain's materials and the robot's ``links`` when given)."""
    v = int(label)
    if v == NOTHING:
        return "nothing"
    if v < ROBOT:
        m = v - TERRAIN
        return f"terrain:{terrain.materials[m].name if terrain is not None else m}"
    if v < OBSTACLE:
        row = v - ROBOT
        return f"link:{links[row] if links is not None else row}"
    return f"obstacle:{v - OBSTACLE}"


def terrain_face_labels(terrain, vertices: np.ndarray, faces: np.ndarray, material: np.ndarray) -> np.ndarray:
    """(m,) int64 label of each terrain face: TERRAIN + material, or OBSTACLE + i on an obstacle field's
    obstacle i. A ValueError when a label would not fit LABEL_DTYPE."""
    if len(material) and int(material.max()) >= MAX_MATERIALS:
        raise ValueError(f"terrain '{terrain.name}' has {int(material.max()) + 1} materials; labels hold at most "
                         f"{MAX_MATERIALS}")
    label = TERRAIN + np.asarray(material, dtype=np.int64)
    if terrain.part_count and len(faces):            # a kind with parts (an obstacle field): Terrain.parts
        if terrain.part_count > MAX_OBSTACLES:
            raise ValueError(f"terrain '{terrain.name}' has {terrain.part_count} obstacles; labels hold at most "
                             f"{MAX_OBSTACLES}")
        part = terrain.parts(vertices[faces].mean(axis=1))
        label[part >= 0] = OBSTACLE + part[part >= 0]
    return label


@njit(cache=True, nogil=True)
def ray_labels(distance, link, material, geom_t, prim_t, face_label, label):
    """Per ray: ROBOT + link row where a link was hit, the terrain face's label where the terrain was
    (an obstacle's, else TERRAIN + the hit's material, which refinement may have changed), else NOTHING.
    geom_t, prim_t: the terrain's Embree hits of these rays (length 0: no terrain scene)."""
    has_t = geom_t.shape[0] == distance.shape[0]
    for i in range(distance.shape[0]):
        part = face_label[prim_t[i]] if has_t and geom_t[i] >= 0 else NOTHING
        label[i] = hit_label(distance[i], link[i], material[i], part)


@njit(cache=True, nogil=True, inline="always")
def hit_label(distance, link, material, part):
    """A ray's label (ray_labels' per ray) from its range, link row, material and ``part``: its terrain
    face's label (an obstacle's is >= OBSTACLE), NOTHING when no terrain face was hit."""
    if not math.isfinite(distance):
        return NOTHING
    if link >= 0:
        return ROBOT + link
    if part >= OBSTACLE:
        return part
    if material >= 0:
        return TERRAIN + material
    return NOTHING


def labels_of(hits) -> np.ndarray:
    """The hits' labels (n,) LABEL_DTYPE: the back end's, or, from one that gives none, ROBOT + link for a
    link, TERRAIN (material 0) for any other hit, NOTHING for a miss."""
    if hits.label is not None:
        return hits.label
    link = np.asarray(hits.link)
    label = np.where(link >= 0, ROBOT + link, TERRAIN)
    label[~np.isfinite(hits.distance)] = NOTHING
    return label.astype(LABEL_DTYPE)


def relabel_refined(rays: np.ndarray, distance, material, label) -> None:
    """The labels of terrain hits refined onto the exact surface (``rays``), again from their material after
    refinement (NOTHING where it moved out of range); an obstacle's label stays (refinement keeps a hit on
    its obstacle)."""
    if not rays.size:
        return
    old = label[rays]
    hit = np.isfinite(distance[rays])
    new = np.where(hit, TERRAIN + material[rays], NOTHING)
    label[rays] = np.where(hit & (old >= OBSTACLE), old, new)
