"""The sign of a mesh terrain's grid from the generalised winding number (``sign: winding_number``).

    w(p) = (1/4π) Σ_faces Ω_f(p)        Ω_f the signed solid angle face f subtends at p
                                        (Jacobson, Kavan & Sorkine-Hornung, "Robust inside-outside
                                        segmentation using generalized winding numbers", SIGGRAPH 2013)

w is ±1 inside a closed mesh (the sign is the normals' orientation: +1 for outward normals), 0 outside,
and degrades gracefully on an open one: inside an open tube w ≈ ±(1 − Ω_openings/4π), falling to ±½ at
the opening's plane; across a hole it moves by the hole's solid angle over 4π only, where a
pseudonormal's sign (the side the closest feature faces) can flip. The enclosed side is |w| ≥ ½, whatever
way the normals point: the grid is d = −|d| there, +|d| elsewhere (the mesh's inside is negative, as for
``sign: pseudonormal``), and ``inside: free`` makes the enclosed side the free one. libigl's
``fast_winding_number`` (Barnes-Hut over the faces, Barill et al. 2018) evaluates it; the unsigned
distance is libigl's exact ``point_mesh_squared_distance``.
"""

from __future__ import annotations

import numpy as np


def _igl():
    try:
        import igl
    except ImportError:
        from snakesim.framework import ConfigError

        raise ConfigError("sign: winding_number needs libigl (pip install libigl)", "<mesh terrain>", "sign") from None
    return igl


def winding_numbers(vertices, faces, points) -> np.ndarray:
    """Generalised winding number (n,) of each point (n, 3) m."""
    igl = _igl()
    return np.asarray(igl.fast_winding_number(np.ascontiguousarray(vertices, dtype=np.float64),
                                              np.ascontiguousarray(faces, dtype=np.int64),
                                              np.ascontiguousarray(points, dtype=np.float64)), dtype=np.float64)


def winding_signed_distance(vertices, faces, points) -> np.ndarray:
    """Exact distance to the mesh (n,) m, negative where |w| ≥ ½ (the enclosed side)."""
    igl = _igl()
    V = np.ascontiguousarray(vertices, dtype=np.float64)
    F = np.ascontiguousarray(faces, dtype=np.int64)
    P = np.ascontiguousarray(points, dtype=np.float64)
    dist = np.sqrt(np.asarray(igl.point_mesh_squared_distance(P, V, F)[0], dtype=np.float64))
    return np.where(np.abs(winding_numbers(V, F, P)) >= 0.5, -dist, dist)


def orientation(vertices, faces, values: np.ndarray, lo, h: float, samples: int = 256) -> float:
    """+1 when the normals point out of the enclosed side (w > 0 on it), −1 when into it: the sign of the
    mean winding number at the ``samples`` grid nodes lo + h (i, j, k) deepest on the enclosed side
    (``values`` < 0, the mesh's convention); +1 when nothing is enclosed (an open sheet)."""
    flat = values.ravel()
    inside = np.flatnonzero(flat < 0)
    if not len(inside):
        return 1.0
    deepest = inside[np.argsort(flat[inside], kind="stable")[:samples]]
    nodes = np.asarray(lo, dtype=np.float64) + h * np.stack(np.unravel_index(deepest, values.shape), axis=1)
    return 1.0 if winding_numbers(vertices, faces, nodes).mean() >= 0 else -1.0
