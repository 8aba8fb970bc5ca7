"""Small watertight example meshes (for terrains/ assets and tests).

    python -m snakesim.components.terrain.meshgen terrains/box-channel.stl
"""

from __future__ import annotations

import sys

import numpy as np


def box_channel_mesh(length: float = 3.0, half_width: float = 0.5, gap: float = 0.4, wall_height: float = 0.5,
                     floor_depth: float = 0.2):
    """Ice block along x, cross-section a U: floor slab z in [-floor_depth, 0], walls up to
    wall_height, a channel |y| < gap/2 between them. Returns a watertight trimesh.Trimesh."""
    import trimesh
    W, g, H, D = half_width, 0.5 * gap, wall_height, floor_depth
    poly = np.array([(-W, -D), (W, -D), (W, 0), (W, H), (g, H), (g, 0), (-g, 0), (-g, H), (-W, H), (-W, 0)])
    cap = np.array([(0, 1, 2), (0, 2, 5), (0, 5, 6), (0, 6, 9), (5, 2, 3), (5, 3, 4), (9, 6, 7), (9, 7, 8)])
    n = len(poly)
    front = np.column_stack([np.zeros(n), poly])            # x = 0
    back = np.column_stack([np.full(n, length), poly])      # x = length
    verts = np.vstack([front, back])
    faces = [cap[:, ::-1], cap + n]                          # caps: outward -x, +x
    for a in range(n):
        b = (a + 1) % n
        faces.append(np.array([(a, b, b + n), (a, b + n, a + n)]))
    mesh = trimesh.Trimesh(verts, np.vstack(faces), process=True)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    return mesh


if __name__ == "__main__":
    box_channel_mesh().export(sys.argv[1] if len(sys.argv) > 1 else "box-channel.stl")
