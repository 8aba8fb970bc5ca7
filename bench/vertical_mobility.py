"""Vertical mobility scenes at their production step: real-time factor, the field test's evaluation, pictures.

    .venv/bin/python bench/vertical_mobility.py [--json FILE] [--pictures DIR]

One line per scene: the run's real-time factor (simulated / wall s, one warm-up run first so numba's
compilation is not counted), its stop, and the evaluation's contact / hold / distance / failure
(components/monitors/vertical_mobility.py, summary.json reports/evaluation). ``--pictures DIR`` also draws
each scene's run (DIR/<scene>.png): link origins at 7 instants in 3-D with the walls, and the tail's height
with the screws' wall loads and the controller's phase over time.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from snakesim.framework.session import load_session

SCENES = ["walls-body-brace", "walls-body-brace-climb", "walls-body-brace-down", "walls-brace-climb",
          "walls-brace-climb-down", "walls-brace-climb-fail", "parallel-walls-climb", "tube-brace-descend",
          "u-channel-brace-traverse", "u-channel-body-brace-traverse", "tube-body-brace", "moulin-brace-down",
          "moulin-brace-down-inclined", "tube-body-brace-descend"]
PICTURES = ["walls-brace-climb", "walls-brace-climb-down", "walls-brace-climb-fail", "tube-brace-descend",
            "u-channel-body-brace-traverse", "tube-body-brace", "tube-body-brace-descend"]


def measure(scene: str) -> tuple[dict, object, object]:
    load_session(scene, sim_overrides={"duration": 0.2}).run()            # warm-up: JIT compilation
    s = load_session(scene)
    r = s.run()
    sm, ev = r.summary, r.summary.get("reports", {}).get("evaluation", {})
    row = {"scene": scene, "integrator": s.integrator.name, "dt_s": sm["dt_s"], "sim_time_s": sm["sim_time_s"],
           "wall_time_s": sm["wall_time_s"], "real_time_factor": sm["real_time_factor"],
           "stop_reason": sm["stop_reason"], "evaluation": ev}
    return row, s, r


def draw(scene: str, s, r, out: Path) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [l.name for l in s.plan.components["robot"].robot.tree.links]
    t = np.asarray(r["t"])
    P = np.asarray(r["robot.link_poses"]).reshape(len(t), len(names), 7)[:, :, :3]
    chain = [i for i, n in enumerate(names) if n.startswith(("tail", "knuckle_", "module_"))]
    screws = [i for i, n in enumerate(names) if n.startswith("screw_")]
    frames = np.unique(np.linspace(0, len(t) - 1, 7).astype(int))
    fig = plt.figure(figsize=(11, 5))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    cmap = plt.get_cmap("viridis")
    for j, f in enumerate(frames):
        c = cmap(j / max(1, len(frames) - 1))
        ax.plot(*P[f, chain].T, "-", color=c, lw=1.5, label=f"t = {t[f]:.1f} s")
        ax.scatter(*P[f, screws].T, color=c, s=10)
    pts = P[:, chain + screws].reshape(-1, 3)
    lo, hi = pts.min(0), pts.max(0)
    mid, half = (lo + hi) / 2, (hi - lo).max() / 2 + 0.1
    gap = getattr(s.plan.components["terrain"].p, "name", "")
    xs, zs = np.meshgrid([mid[0] - half, mid[0] + half], [mid[2] - half, mid[2] + half])
    if "walls" in str(gap):
        for y in (-0.175, 0.175):                                             # parallel-walls-0.35
            ax.plot_surface(xs, np.full_like(xs, y), zs, color="0.6", alpha=0.15)
    elif "u-channel" in str(gap):                                             # its walls, above the floor's axis
        from snakesim.components.terrain.spec import load_terrain
        u = load_terrain(str(gap))
        zw = np.maximum(zs, u.origin[2])
        for y in (-u.width / 2, u.width / 2):
            ax.plot_surface(xs, np.full_like(xs, y), zw, color="0.6", alpha=0.15)
    elif "tube" in str(gap):                                                  # a vertical tube about the z axis
        from snakesim.components.terrain.spec import load_terrain
        R = float(load_terrain(str(gap)).radius)
        a, zz = np.meshgrid(np.linspace(0, 2 * np.pi, 41), [mid[2] - half, mid[2] + half])
        ax.plot_wireframe(R * np.cos(a), R * np.sin(a), zz, color="0.6", lw=0.3, alpha=0.5)
    ax.set_xlim(mid[0] - half, mid[0] + half), ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)
    ax.set_xlabel("x m"), ax.set_ylabel("y m"), ax.set_zlabel("z m")
    ax.set_title(f"{scene}: link origins (screws dotted), walls / tube grey", fontsize=9)
    ax.legend(fontsize=6, loc="upper left")
    ax2 = fig.add_subplot(1, 2, 2)
    h = P[:, names.index("tail"), 2]
    ax2.plot(t, h - h[0], "k", lw=2, label="tail height − start (m)")
    ax2.set_xlabel("t s"), ax2.set_ylabel("m"), ax2.grid(True, lw=0.3)
    phase = np.asarray(r["brace.phase"])[:, 0]
    for k, col in ((1, "tab:orange"), (2, "tab:green")):
        m = phase == k
        if m.any():
            ax2.axvspan(t[m][0], t[m][-1], color=col, alpha=0.15,
                        label="screws driving" if k == 1 else "braked again")
    ax3 = ax2.twinx()
    Fn = np.asarray(r["contact.screw_normal_force"])
    for j in range(Fn.shape[1]):
        ax3.plot(t, Fn[:, j], lw=0.8, label=f"screw {j} wall load")
    ax3.set_ylabel("N")
    ev = r.summary.get("reports", {}).get("evaluation", {})
    if "hold" in ev:
        ax2.set_title(f"hold {ev['hold']['longest_s']:.1f} s, up {ev['vertical_distance']['up_m']:.2f} m, "
                      f"down {ev['vertical_distance']['down_m']:.2f} m; {r.summary['stop_reason']}"[:110], fontsize=8)
    else:                                                                     # a traverse_evaluation
        x = P[:, names.index("tail"), 0]
        ax2.plot(t, x - x[0], "b", lw=2, label="tail x − start (m, along the channel)")
        ax2.set_title(f"traverse {ev['distance_m']:.2f} m, steady {ev['steady_speed_m_s']:.3f} m/s "
                      f"({100 * ev.get('efficiency', float('nan')):.0f} % of {ev.get('reference_speed_m_s', 0):.3f}); "
                      f"{r.summary['stop_reason']}"[:110], fontsize=8)
    h1, l1 = ax2.get_legend_handles_labels()
    h2, l2 = ax3.get_legend_handles_labels()
    ax2.legend(h1 + h2, l1 + l2, fontsize=6, loc="upper left")
    fig.tight_layout()
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{scene}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv):
    rows = []
    pictures = Path(argv[argv.index("--pictures") + 1]) if "--pictures" in argv else None
    for sc in SCENES:
        row, s, r = measure(sc)
        rows.append(row)
        if pictures is not None and sc in PICTURES:
            print(f"wrote {draw(sc, s, r, pictures)}", flush=True)
    print(f"{'scene':24s} {'integrator':12s} {'dt ms':>6s} {'sim s':>6s} {'RTF':>6s}  contact s  hold s   up m  down m  stop")
    for r in rows:
        ev = r["evaluation"]
        vd = ev.get("vertical_distance", {})
        print(f"{r['scene']:24s} {r['integrator']:12s} {1e3 * r['dt_s']:6.3g} {r['sim_time_s']:6.3g} "
              f"{r['real_time_factor']:6.3g}  {ev.get('contact', {}).get('time_s', float('nan')):9.3g}  "
              f"{ev.get('hold', {}).get('longest_s', float('nan')):6.3g}  {vd.get('up_m', float('nan')):5.3g}  "
              f"{vd.get('down_m', float('nan')):6.3g}  {r['stop_reason']}")
    if "--json" in argv:
        with open(argv[argv.index("--json") + 1], "w") as f:
            json.dump(rows, f, indent=2, default=float)


if __name__ == "__main__":
    main(sys.argv[1:])
