"""Picture of the moulin down-climb (assemblies/moulin-brace-down.yaml, a vertical slot; or its inclined variant
moulin-brace-down-inclined.yaml with --scene) for the README.

    .venv/bin/python bench/moulin_brace_down_picture.py [OUT.png] [--scene NAME] [-p KEY=VALUE ...]

Runs the scene and draws: (top left) the tail's height and the tether's tension over time, the static hold
(the evaluation's longest window) shaded; (top right) the robot's link origins in the slot's plane (x, z) at 7
instants, the slot's ends; (bottom) the robot seen down the shaft's axis at 5 instants, in the slot's
cross-section (u along the slot, v across it) with the walls at its depth. Prints the evaluation.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from snakesim.components.terrain import load_terrain
from snakesim.framework.session import load_session


def main(argv):
    out = Path(argv[0]) if argv and not argv[0].startswith("-") else Path("docs/images/moulin-brace-down.png")
    over = [a for i, a in enumerate(argv) if i > 0 and argv[i - 1] == "-p"]
    scene = next((a for i, a in enumerate(argv) if i > 0 and argv[i - 1] == "--scene"), "moulin-brace-down")
    s = load_session(scene, overrides=over)
    r = s.run()
    ev = r.summary["reports"]["evaluation"]
    print(json.dumps(r.summary["reports"], indent=1))
    print("stop:", r.summary["stop_reason"], " real-time factor", round(r.summary["real_time_factor"], 2))

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    terrain = load_terrain(s.plan.components["terrain"].p.name)   # the scene's terrain (its `terrain` parameter)
    names = [l.name for l in s.plan.components["robot"].robot.tree.links]
    t = np.asarray(r["t"])
    P = np.asarray(r["robot.link_poses"]).reshape(len(t), len(names), 7)[:, :, :3]
    T = np.asarray(r["tether.tension"]).reshape(len(t), -1)[:, 0]
    chain = [i for i, n in enumerate(names) if n.startswith(("tail", "knuckle_", "module_"))]
    screws = [i for i, n in enumerate(names) if n.startswith("screw_")]
    fig = plt.figure(figsize=(13, 8.5))
    gs = fig.add_gridspec(2, 2, height_ratios=[1.25, 1.0])
    a1, a3, a2 = fig.add_subplot(gs[0, 0]), fig.add_subplot(gs[0, 1]), fig.add_subplot(gs[1, :])

    h = P[:, names.index("tail"), 2]
    a1.plot(t, h - h[0], "k", lw=2, label="tail height − start (m)")
    hold = ev["hold"]
    a1.axvspan(hold["from_s"], hold["to_s"], color="tab:green", alpha=0.15,
               label=f"static hold {hold['longest_s']:.1f} s (drift < {1000 * hold['drift_tolerance_m']:.0f} mm)")
    a1.set_xlabel("t s"), a1.set_ylabel("m"), a1.grid(True, lw=0.3)
    b1 = a1.twinx()
    b1.plot(t, T, color="tab:red", lw=1, label="belay tether tension (N)")
    b1.set_ylabel("tether N", color="tab:red"), b1.set_ylim(-1, max(10.0, 1.2 * T.max()))
    a1.set_title(f"down {ev['vertical_distance']['down_m']:.2f} m, max tether {ev['tether']['max_tension_N']:.1f} N, "
                 f"max tilt {ev['max_tilt_deg']:.1f}°", fontsize=9)
    l1, n1 = a1.get_legend_handles_labels()
    l2, n2 = b1.get_legend_handles_labels()
    a1.legend(l1 + l2, n1 + n2, fontsize=7, loc="lower left")

    # down the shaft: (u, v) of the slot's frame, walls at the robot's depth
    R, o = terrain.R, terrain.origin
    cmap = plt.get_cmap("viridis")
    frames = np.unique(np.linspace(0, len(t) - 1, 5).astype(int))
    for j, f in enumerate(frames):
        c = cmap(j / max(1, len(frames) - 1))
        loc = (P[f] - o) @ R
        a2.plot(loc[chain, 0], loc[chain, 1], "-", color=c, lw=1.5, label=f"t = {t[f]:.0f} s")
        a2.scatter(loc[screws, 0], loc[screws, 1], color=c, s=12)
        s_c = float(loc[chain, 2].mean())
        W = terrain.wall_points((s_c - 1e-3, s_c + 1e-3), 0.02)[:, 0]
        wl = (W - o) @ R
        a2.plot(wl[:, 0], wl[:, 1], color=c, lw=0.6, alpha=0.7)
    a2.set_xlim(-terrain.a - 0.1, terrain.a + 0.1), a2.set_ylim(-0.25, 0.25), a2.set_aspect("equal")
    a2.grid(True, lw=0.3)
    a2.set_xlabel("along the slot u m"), a2.set_ylabel("across v m")
    a2.set_title("down the shaft: link origins (screws dotted) and the walls there", fontsize=9)
    a2.legend(fontsize=6, loc="upper left", ncol=5)

    frames = np.unique(np.linspace(0, len(t) - 1, 7).astype(int))
    for j, f in enumerate(frames):
        c = cmap(j / max(1, len(frames) - 1))
        a3.plot(P[f, chain, 0], P[f, chain, 2], "-", color=c, lw=1.5)
        a3.scatter(P[f, screws, 0], P[f, screws, 2], color=c, s=10)
    sa = np.linspace(-8.0, 0.0, 2)
    for u in (-terrain.a, terrain.a):           # the slot's ends in the vertical plane of the shaft
        line = o + np.outer(sa, R[:, 2]) + u * R[:, 0]
        a3.plot(line[:, 0], line[:, 2], color="0.5", lw=0.8)
    a3.axhline(terrain.top, color="0.3", lw=0.8)
    lo, hi = P[:, chain].reshape(-1, 3).min(0), P[:, chain].reshape(-1, 3).max(0)
    a3.set_xlim(min(lo[0] - 0.6, -terrain.a - 0.2) if abs(R[2, 2]) > 0.99 else lo[0] - 0.6,
                max(hi[0] + 0.6, terrain.a + 0.2) if abs(R[2, 2]) > 0.99 else hi[0] + 0.6)
    a3.set_ylim(lo[2] - 0.6, max(hi[2] + 0.3, terrain.top + 0.2))
    a3.set_aspect("equal"), a3.grid(True, lw=0.3)
    a3.set_xlabel("x m"), a3.set_ylabel("z m")
    a3.set_title("side view: the slot's ends (grey), the surface, the robot at 7 instants", fontsize=9)
    shaft = "a vertical" if abs(R[2, 2]) > 0.99 else f"an inclined ({np.degrees(np.arcsin(R[2, 2])):.1f} deg)"
    fig.suptitle(f"{scene}: EELS 1.5 braced across {shaft} slot section of a synthetic moulin", fontsize=10)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    print("wrote", out)


if __name__ == "__main__":
    main(sys.argv[1:])
