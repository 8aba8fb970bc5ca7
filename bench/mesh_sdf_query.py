"""Mesh terrain queries: the SDF grid's trilinear path against the exact band (terrain/mesh_exact.py) and a BVH.

The mesh is a synthetic scanned moulin: a slot shaft 5.2 x 0.344 m (a stadium), 7 m deep, open at both ends,
rough walls (1 cm), two holes, normals into the void, ~100k faces. It is loaded as a terrain twice, with
``sign: winding_number, inside: free``: with the grid alone and with ``exact_band``. Query sets of 1000
points: ``near`` (within the band of the wall, both sides) and ``far`` (the void's centre plane and the ice
0.1-0.2 m behind the wall), and ``near40`` (40 of the near ones: a contact step's count). For each: µs per 1000 queries through ``Terrain._query`` (what the contact
calls), best of ``--repeats``, and libigl's AABB tree (a BVH, built once; unsigned distance only, so a
lower bound of a BVH's signed query). Also: the build times (grid, cell lists), the cell lists' size, and
the exact band's distance against libigl's (the largest difference).

    .venv/bin/python bench/mesh_sdf_query.py [--faces 100000] [--resolution 0.03] [--band 0.02]
                                             [--store DIR] [--json bench/results/mesh_sdf_query.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HALF_LENGTH, HALF_WIDTH, DEPTH = 2.6, 0.172, 7.0      # the slot (m)


def slot_moulin(faces: int, seed: int = 0):
    """(vertices, faces) of the rough open slot shaft, about ``faces`` triangles, normals into the void."""
    straight = 2 * (HALF_LENGTH - HALF_WIDTH)
    perimeter = 2 * straight + 2 * np.pi * HALF_WIDTH
    nz = int(np.sqrt(faces / 2 * DEPTH / perimeter)) + 1
    nt = int(faces / 2 / (nz - 1))
    s = np.linspace(0, perimeter, nt, endpoint=False)
    z = np.linspace(-DEPTH, 0, nz)
    # the stadium's centre line point and outward normal at arc length s
    x, y, nx, ny = np.empty(nt), np.empty(nt), np.empty(nt), np.empty(nt)
    c = HALF_LENGTH - HALF_WIDTH
    seg = [straight, np.pi * HALF_WIDTH, straight, np.pi * HALF_WIDTH]
    edges = np.cumsum([0] + seg)
    for k, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        m = (s >= a) & (s < b)
        u = s[m] - a
        if k == 0:
            x[m], y[m], nx[m], ny[m] = -c + u, -HALF_WIDTH, 0, -1
        elif k == 2:
            x[m], y[m], nx[m], ny[m] = c - u, HALF_WIDTH, 0, 1
        else:
            ang = u / HALF_WIDTH + (-np.pi / 2 if k == 1 else np.pi / 2)
            cx = c if k == 1 else -c
            x[m], y[m], nx[m], ny[m] = cx + HALF_WIDTH * np.cos(ang), HALF_WIDTH * np.sin(ang), np.cos(ang), np.sin(ang)
    rng = np.random.default_rng(seed)
    S, Z = np.meshgrid(s, z, indexing="ij")
    rough = np.zeros_like(S)
    for _ in range(12):                                         # 1 cm of smooth roughness
        kx, kz, ph = rng.uniform(2, 12) * 2 * np.pi / perimeter * rng.integers(1, 6), rng.uniform(1, 6), \
            rng.uniform(0, 2 * np.pi)
        rough += np.sin(kx * S + kz * Z + ph)
    rough *= 0.01 / rough.std()
    V = np.stack([x[:, None] + rough * nx[:, None], y[:, None] + rough * ny[:, None], Z], -1).reshape(-1, 3)
    i, j = (a.ravel() for a in np.meshgrid(np.arange(nt), np.arange(nz - 1), indexing="ij"))
    a, b, cc, d = i * nz + j, (i + 1) % nt * nz + j, (i + 1) % nt * nz + j + 1, i * nz + j + 1
    F = np.concatenate([np.stack([a, cc, b], 1), np.stack([a, d, cc], 1)])
    centre = V[F].mean(1)
    holes = ((np.abs(centre[:, 0] - 1.0) < 0.15) & (centre[:, 1] > 0) & (np.abs(centre[:, 2] + 3.0) < 0.15)) | \
            ((np.abs(centre[:, 0] + 2.0) < 0.2) & (centre[:, 1] < 0) & (np.abs(centre[:, 2] + 5.0) < 0.3))
    return V, F[~holes]


def query_sets(V, F, band: float, n: int = 1000, seed: int = 1):
    """near: points within band/2 of random face centres along their normals, both sides; far: the void's
    centre plane and 0.1-0.2 m behind the wall."""
    rng = np.random.default_rng(seed)
    tri = V[F]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    pick = rng.integers(0, len(F), n)
    near = tri[pick].mean(1) + rng.uniform(-band / 2, band / 2, n)[:, None] * normal[pick]
    pick = rng.integers(0, len(F), n // 2)
    behind = tri[pick].mean(1) - rng.uniform(0.1, 0.2, n // 2)[:, None] * normal[pick]    # normals into the void
    centre = np.column_stack([rng.uniform(-2.4, 2.4, n - n // 2), np.zeros(n - n // 2),
                              rng.uniform(-6.5, -0.5, n - n // 2)])
    return {"near": near, "far": np.concatenate([behind, centre]), "near40": near[:40]}


def per_1000(f, p, repeats: int) -> float:
    f(p)                                                          # compiled / warm
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        f(p)
        best = min(best, time.perf_counter() - t0)
    return 1e6 * best * 1000 / len(p)


def main(argv):
    import igl
    import trimesh

    from snakesim.components.terrain import mesh_terrain

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--faces", type=int, default=100_000)
    ap.add_argument("--resolution", type=float, default=0.03)
    ap.add_argument("--band", type=float, default=0.02)
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--store", default=None, help="terrain store (default: a temporary folder: builds timed)")
    ap.add_argument("--json", default="bench/results/mesh_sdf_query.json")
    a = ap.parse_args(argv)

    V, F = slot_moulin(a.faces)
    folder = Path(tempfile.mkdtemp(prefix="mesh_sdf_query_"))
    path = folder / "moulin.ply"
    trimesh.Trimesh(V, F, process=False).export(path)
    mesh = trimesh.load(path, process=False)
    V, F = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)
    store = a.store or folder / "store"
    kw = dict(resolution=a.resolution, padding=0.15, inside="free", sign="winding_number", store=store)
    t0 = time.perf_counter()
    grid = mesh_terrain(path, **kw)
    t_grid = time.perf_counter() - t0
    t0 = time.perf_counter()
    exact = mesh_terrain(path, exact_band=a.band, **kw)        # the grid from the store, the band built
    t_band = time.perf_counter() - t0
    ns = exact.near_surface
    lists = np.diff(ns.start)
    tree = igl.AABB()
    tree.init(V, F)

    rows = []
    for name, p in query_sets(V, F, a.band).items():
        g = grid.query(p)
        q = exact.query(p)
        in_band = np.abs(g.distance) < a.band
        d_igl = np.sqrt(tree.squared_distance(V, F, p)[0])
        row = {"points": name, "n": len(p), "in_band": int(in_band.sum()),
               "grid_us_per_1000": per_1000(grid._query, p, a.repeats),
               "exact_band_us_per_1000": per_1000(exact._query, p, a.repeats),
               "bvh_unsigned_us_per_1000": per_1000(lambda x: tree.squared_distance(V, F, x), p, a.repeats),
               "grid_max_error_m": float(np.abs(np.abs(g.distance) - d_igl).max()),
               "exact_max_error_in_band_m": float(np.abs(np.abs(q.distance) - d_igl)[in_band].max())
               if in_band.any() else 0.0}
        rows.append(row)
    out = {"faces": int(len(F)), "grid_shape": list(grid.values.shape), "resolution_m": a.resolution,
           "exact_band_m": a.band, "grid_build_s": t_grid, "band_build_s": t_band,
           "cell_list_entries": int(ns.start[-1]), "cell_lists_bytes": int(ns.start.nbytes + ns.tris.nbytes),
           "triangles_per_nonempty_cell_mean": float(lists[lists > 0].mean()),
           "triangles_per_nonempty_cell_max": int(lists.max()), "rows": rows}

    print(f"synthetic slot moulin: {len(F)} faces, grid {grid.values.shape} at {a.resolution} m, band {a.band} m")
    print(f"build: grid (winding number) {t_grid:.2f} s, exact band (lists, pseudonormals, orientation, store "
          f"entry) {t_band:.2f} s; {ns.start[-1]} entries "
          f"({(ns.start.nbytes + ns.tris.nbytes) / 1e6:.1f} MB), {out['triangles_per_nonempty_cell_mean']:.1f} "
          f"triangles per non-empty cell (max {out['triangles_per_nonempty_cell_max']})")
    print(f"{'points':6s} {'in band':>8s} {'grid µs/1000':>13s} {'exact µs/1000':>14s} {'BVH µs/1000':>12s} "
          f"{'grid err m':>11s} {'exact err m':>12s}")
    for r in rows:
        print(f"{r['points']:6s} {r['in_band']:8d} {r['grid_us_per_1000']:13.1f} {r['exact_band_us_per_1000']:14.1f} "
              f"{r['bvh_unsigned_us_per_1000']:12.1f} {r['grid_max_error_m']:11.2e} "
              f"{r['exact_max_error_in_band_m']:12.2e}")
    if a.json:
        Path(a.json).parent.mkdir(parents=True, exist_ok=True)
        Path(a.json).write_text(json.dumps(out, indent=2))
        print(f"wrote {a.json}")


if __name__ == "__main__":
    main(sys.argv[1:])
