"""Picture of a scan file (the shipped synthetic moulin scan by default): points coloured by depth, two views.

    .venv/bin/python bench/scan_pictures.py [SCAN.laz|.las|.ply] [-o PNG]

Left: the whole cloud seen obliquely from above the mouth (every 5th point); right: the −y wall seen face-on
from inside the slot (x along the slot, z up; the points with y < 0), where the holes show: the masked patch,
and the far end's flat walls lost at grazing incidence. Default output docs/images/moulin-slot-scan.png.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def read_points(path: Path) -> np.ndarray:
    """(n, 3) m of a LAS/LAZ (laspy) or PLY (trimesh) point cloud."""
    if path.suffix.lower() == ".ply":
        import trimesh

        return np.asarray(trimesh.load(path, process=False).vertices, dtype=float)
    import laspy

    las = laspy.read(path)
    return np.column_stack([las.x, las.y, las.z]).astype(float)


def picture(points: np.ndarray, out: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(13, 6.5))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    few = points[::5]
    sc = ax.scatter(few[:, 0], few[:, 1], few[:, 2], c=few[:, 2], cmap="viridis", s=0.2, linewidths=0)
    ax.set_box_aspect(np.ptp(few, axis=0) + (0, 1.0, 0))
    ax.view_init(elev=25, azim=-60)
    ax.set_xlabel("x m (along the slot)")
    ax.set_ylabel("y m")
    ax.set_yticks([-0.2, 0.0, 0.2])
    ax.set_zlabel("z m")
    ax.set_title(f"{len(points)} points, oblique (every 5th)")
    fig.colorbar(sc, ax=ax, shrink=0.6, label="depth z (m)")
    ax2 = fig.add_subplot(1, 2, 2)
    wall = points[points[:, 1] < 0]
    ax2.scatter(wall[:, 0], wall[:, 2], c=wall[:, 2], cmap="viridis", s=0.05, linewidths=0)
    ax2.set_aspect("equal")
    ax2.set_xlabel("x m (along the slot)")
    ax2.set_ylabel("z m")
    ax2.set_title(f"the -y wall face-on ({len(wall)} points)")
    fig.suptitle(title)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scan", nargs="?", default=str(ROOT / "terrains/scans/moulin-slot-scan.laz"))
    ap.add_argument("-o", "--output", default=str(ROOT / "docs/images/moulin-slot-scan.png"))
    a = ap.parse_args()
    scan = Path(a.scan)
    picture(read_points(scan), Path(a.output), f"{scan.name}: synthetic scan coloured by depth")
    print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
