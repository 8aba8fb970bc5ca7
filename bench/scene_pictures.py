"""Pictures of the scenes for README.md: link origins over time (matplotlib 3-D) from a recorded
run of each scene, plus a top view of the tail's trajectory for the traverse.

    .venv/bin/python bench/scene_pictures.py [--out docs/images] [--scene NAME ...]

Each scene runs at its own settings for the horizon below (the traverse: its full 45 s).
"""

from __future__ import annotations

import sys
from pathlib import Path

import click
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "validation"))
from validation_scenes import run  # noqa: E402

HORIZONS = {"surface-screw-traverse": 45.0, "tube-dangling": 6.0, "parallel-walls-climb": 4.0,
            "u-channel": 6.0, "moulin": 6.0, "dem-surface": 15.0, "eels-lateral-undulation": 8.0,
            "eels-sidewinding": 8.0, "mini-eels-crawl": 10.0, "u-channel-brace-traverse": 20.0, "mini-eels-pipe-climb": 4.0}


def draw(scene, horizon, out: Path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s, r = run(scene, [], {"duration": horizon})
    names = s.plan.components["robot"].robot.links
    keep = [i for i, n in enumerate(names) if n.startswith(("tail", "module_", "knuckle_", "screw_"))]
    P = np.asarray(r["robot.link_poses"]).reshape(len(r["t"]), len(names), 7)[:, :, :3]
    t = np.asarray(r["t"])
    frames = np.unique(np.linspace(0, len(t) - 1, 7).astype(int))
    order = [i for i in keep if names[i].startswith(("tail", "knuckle_", "module_"))]
    fig = plt.figure(figsize=(11, 5) if scene == "surface-screw-traverse" else (6, 5))
    ax = fig.add_subplot(1, 2 if scene == "surface-screw-traverse" else 1, 1, projection="3d")
    cmap = plt.get_cmap("viridis")
    for j, f in enumerate(frames):
        c = cmap(j / max(1, len(frames) - 1))
        ax.plot(*P[f, order].T, "-", color=c, lw=1.5, label=f"t = {t[f]:.1f} s")
        scr = [i for i in keep if names[i].startswith("screw_")]
        ax.scatter(*P[f, scr].T, color=c, s=10)
    lo, hi = P[:, keep].reshape(-1, 3).min(0), P[:, keep].reshape(-1, 3).max(0)
    mid, half = (lo + hi) / 2, (hi - lo).max() / 2 + 0.1
    ax.set_xlim(mid[0] - half, mid[0] + half), ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)
    ax.set_xlabel("x m"), ax.set_ylabel("y m"), ax.set_zlabel("z m")
    ax.set_title(f"{scene}: link origins (screws dotted)", fontsize=9)
    ax.legend(fontsize=6, loc="upper left")
    if scene == "surface-screw-traverse":
        ax2 = fig.add_subplot(1, 2, 2)
        pose = np.asarray(r["tail_pose.pose"])
        ph = np.asarray(r["phases.phase"])[:, 0]
        for k in np.unique(ph):
            m = ph == k
            ax2.plot(pose[m, 0], pose[m, 1], lw=2, label="settle" if k < 0 else f"phase {int(k) + 1}")
        ax2.set_aspect("equal"), ax2.grid(True, lw=0.3)
        ax2.set_xlabel("tail x m"), ax2.set_ylabel("tail y m")
        ax2.set_title("tail trajectory, top view (45 s)", fontsize=9)
        ax2.legend(fontsize=7)
    fig.tight_layout()
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"scene-{scene}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path, r.summary


@click.command()
@click.option("--out", default="docs/images", show_default=True)
@click.option("--scene", "only", multiple=True)
def main(out, only):
    for scene, h in HORIZONS.items():
        if only and scene not in only:
            continue
        path, sm = draw(scene, h, Path(out))
        print(f"{path}: {sm['stop_reason']}, RTF {sm['real_time_factor']:.3g}", flush=True)


if __name__ == "__main__":
    main()
