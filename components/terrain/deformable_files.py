"""The deformable terrain's state on disk and in pictures: an npz a later run restores, the rut's numbers,
and a top view of the rut (PNG).

npz layout (``save_state``): ``tile_of`` (tiles x, y) int64 slots, ``plastic``, ``yield_p`` and ``lift`` (used,
32, 32) m, Pa and m of the used tiles (a file without ``lift``, from before bulldozing, reads as none),
``used`` [slots given, pool full, capacity], and ``grid`` [x0, y0, cell, base,
nx, ny] so a reader can tell which terrain it belongs to; ``load_state`` refuses another grid, naming both.
Heights are base + lift − plastic (deformable_kernels.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .deformable import DeformableTerrain
from .deformable_kernels import TILE


def save_state(terrain: DeformableTerrain, path) -> Path:
    """Write ``terrain``'s state (its used tiles) to ``path`` (.npz)."""
    import io

    from snakesim.framework.output_files import write_file

    buf = io.BytesIO()
    np.savez_compressed(buf, grid=terrain.grid, **terrain.snapshot())
    return write_file(path, buf.getvalue())         # whole or not at all, an error naming the file


def load_state(terrain: DeformableTerrain, path, t: float | None = None) -> None:
    """Put a :func:`save_state` file back into ``terrain`` (in place; its version bumps)."""
    with np.load(path) as f:
        if not np.array_equal(f["grid"], terrain.grid):
            raise ValueError(f"{path}: saved from a grid {f['grid'].tolist()} (x0, y0, cell, base, nx, ny), not "
                             f"{terrain.source}'s {terrain.grid.tolist()}")
        snap = {k: f[k] for k in ("tile_of", "plastic", "yield_p", "used")}
        snap["lift"] = f["lift"] if "lift" in f.files else np.zeros_like(snap["plastic"])
        terrain.restore(snap, t)


def rut_summary(terrain: DeformableTerrain) -> dict:
    """The rut's numbers: deformed nodes, deepest point below the base (m), volume pressed out (m³, Σ s_p Δ²),
    tiles used of the pool, and the deformed nodes' bounding box (m, world x, y); with bulldozing also the
    volume heaped (Σ lift Δ²), the net change of the soil's volume (Σ (lift − s_p) Δ²: 0 when all the pressed
    soil was heaped, flow_factor 1) and the highest berm above the base (m)."""
    k = terrain.tiles_used()
    plastic, lift = terrain.state.plastic[:k], terrain.state.lift[:k]
    on = (plastic > 0.0) | (lift != 0.0)
    area = terrain.cell ** 2
    out = {"tiles_used": k, "max_tiles": terrain.max_tiles, "deformed_nodes": int(on.sum()),
           "max_rut_depth_m": float((plastic - lift).max()) if k else 0.0,
           "rut_volume_m3": float(plastic.sum() * area)}
    if terrain.bulldozing is not None:
        out["heaped_volume_m3"] = float(lift.sum() * area)
        out["net_volume_m3"] = float((lift - plastic).sum() * area)
        out["max_berm_height_m"] = float((lift - plastic).max()) if k else 0.0
    if on.any():
        x, y = node_coordinates(terrain)
        out["rut_bounds_m"] = [float(x[on].min()), float(y[on].min()), float(x[on].max()), float(y[on].max())]
    return out


def node_coordinates(terrain: DeformableTerrain) -> tuple[np.ndarray, np.ndarray]:
    """World x, y (m) of every node of the used tiles, shaped as the pool's (used, 32, 32)."""
    k = terrain.tiles_used()
    slots = terrain.state.tile_of
    ti, tj = np.nonzero(slots >= 0)
    order = slots[ti, tj]
    x0, y0, cell = terrain.grid[0], terrain.grid[1], terrain.cell
    a = np.arange(TILE)
    shape = (ti.size, TILE, TILE)
    x, y = np.empty((k, TILE, TILE)), np.empty((k, TILE, TILE))
    x[order] = x0 + np.broadcast_to(ti[:, None, None] * TILE + a[None, :, None], shape) * cell
    y[order] = y0 + np.broadcast_to(tj[:, None, None] * TILE + a[None, None, :], shape) * cell
    return x, y


def rut_picture(terrain: DeformableTerrain, path, title: str = "") -> Path | None:
    """A top view of the rut depth over the deformed area (PNG); None when nothing was deformed."""
    rs = rut_summary(terrain)
    if not rs["deformed_nodes"]:
        return None
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xa, ya, xb, yb = rs["rut_bounds_m"]
    pad = 0.2
    cell = terrain.cell
    xs = np.arange(xa - pad, xb + pad + cell / 2, cell)
    ys = np.arange(ya - pad, yb + pad + cell / 2, cell)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    depth = terrain.rut_depth(X, Y) if X.size <= 400_000 else None
    if depth is None:          # a long run's rut: sample every other node (the picture is ~1000 px wide)
        X, Y = X[::2, ::2], Y[::2, ::2]
        depth = terrain.rut_depth(X, Y)
    fig, ax = plt.subplots(figsize=(7, 6))
    if depth.min() < 0.0:              # berms (bulldozing): below the base blue-green, above it brown
        top = 100.0 * float(np.abs(depth).max())
        im = ax.pcolormesh(X, Y, 100.0 * depth, cmap="BrBG", vmin=-top, vmax=top, shading="auto")
        fig.colorbar(im, ax=ax, label="depth below the base (cm; < 0: berm)")
    else:
        im = ax.pcolormesh(X, Y, 100.0 * depth, cmap="Blues", shading="auto")
        fig.colorbar(im, ax=ax, label="rut depth (cm)")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or f"rut: deepest {100 * rs['max_rut_depth_m']:.1f} cm, {rs['rut_volume_m3'] * 1e3:.1f} L")
    fig.tight_layout()
    import io

    from snakesim.framework.output_files import write_file

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return write_file(path, buf.getvalue())
