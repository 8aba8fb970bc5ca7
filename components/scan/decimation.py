"""Decimation to a face budget: Garland–Heckbert quadric error collapses (Open3D's
``simplify_quadric_decimation``), which keep flat walls' shape and spend the triangles where the
surface bends. The SDF store's grid is computed once, but the viewer and the lidar's ray caster draw and
cast against the mesh itself, so a 150k-face Poisson surface is cut to what they need."""

from __future__ import annotations

import numpy as np

from .open3d_loader import import_open3d
from .reconstruction import compact


def decimate(v: np.ndarray, f: np.ndarray, faces: int):
    """(vertices, faces) with at most about ``faces`` triangles (unchanged when already under it)."""
    if faces <= 0 or len(f) <= faces:
        return v, f
    o3d = import_open3d()
    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(v), o3d.utility.Vector3iVector(f.astype(np.int32)))
    mesh = mesh.simplify_quadric_decimation(target_number_of_triangles=int(faces))
    mesh.remove_degenerate_triangles()
    mesh.remove_duplicated_triangles()
    return compact(np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.triangles, dtype=np.int64))
