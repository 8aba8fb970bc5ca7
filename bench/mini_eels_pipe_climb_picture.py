"""The picture of Mini EELS 1.0 climbing the vertical pipe (assemblies/mini-eels-pipe-climb.yaml) for README.md:
the ring's link origins at a few instants inside the pipe (3-D), and the head's height from first contact
against time with the no-slip advance 2π r_s f (t − t_roll) and the rolling cycles marked.

    .venv/bin/python bench/mini_eels_pipe_climb_picture.py [--out docs/images] [--duration 7]

Prints the evaluation's report (summary.json's reports/evaluation) and the gain of every rolling cycle.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import click
import numpy as np

from snakesim.components.terrain import load_terrain
from snakesim.framework.session import load_session

SCENE = "mini-eels-pipe-climb"


@click.command()
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("docs/images"))
@click.option("--duration", type=float, default=7.0, help="s of simulated time")
def main(out: Path, duration: float):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = load_session(SCENE, sim_overrides={"duration": duration})
    r = s.run()
    ev = r.summary["reports"]["evaluation"]
    prm = s.resolved.parameters
    f, t_roll = float(prm["frequency"]), float(prm["t_roll"])
    pipe_r = float(load_terrain(prm["terrain"]).radius)
    r_s = 0.028             # m, no-slip advance per radian of the rolling phase (2π r_s per cycle, see the scene)
    names = s.plan.components["robot"].robot.links
    t = np.asarray(r["t"])
    P = np.asarray(r["robot.link_poses"]).reshape(len(t), len(names), 7)[:, :, :3]
    h = np.ravel(r["monitor.climb"])

    fig = plt.figure(figsize=(11, 5))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    th = np.linspace(0, 2 * math.pi, 73)
    z_lo, z_hi = P[..., 2].min() - 0.05, P[..., 2].max() + 0.05
    for z in np.linspace(z_lo, z_hi, 6):
        ax.plot(pipe_r * np.cos(th), pipe_r * np.sin(th), z, color="0.8", lw=0.6)
    for a in np.linspace(0, 2 * math.pi, 12, endpoint=False):
        ax.plot([pipe_r * math.cos(a)] * 2, [pipe_r * math.sin(a)] * 2, [z_lo, z_hi], color="0.85", lw=0.5)
    frames = [int(np.argmin(abs(t - x))) for x in np.linspace(t_roll, t[-1], 5)]
    cmap = plt.get_cmap("viridis")
    for j, k in enumerate(frames):
        ax.plot(*P[k].T, "-o", ms=2.5, color=cmap(j / (len(frames) - 1)), lw=2, label=f"t = {t[k]:.1f} s")
    half = max(pipe_r + 0.02, (z_hi - z_lo) / 2)
    ax.set_xlim(-half, half), ax.set_ylim(-half, half), ax.set_zlim((z_lo + z_hi) / 2 - half, (z_lo + z_hi) / 2 + half)
    ax.set_xlabel("x m"), ax.set_ylabel("y m"), ax.set_zlabel("z m")
    ax.set_title("Mini EELS 1.0 in a vertical pipe, r = 0.2 m (link origins)", fontsize=9)
    ax.legend(fontsize=7, loc="upper left")

    ax2 = fig.add_subplot(1, 2, 2)
    ax2.plot(t, h, lw=1.8, label="head module height (evaluation)")
    ideal = np.where(t > t_roll, 2 * math.pi * r_s * f * (t - t_roll), 0.0)
    ax2.plot(t, ideal, "--", color="0.5", lw=1, label="no-slip rolling, 2π r_s f (t − t_roll)")
    cycles = np.arange(t_roll, t[-1] + 1e-9, 1 / f)
    hc = np.interp(cycles, t, h)
    ax2.plot(cycles, hc, "o", color="C3", label="rolling cycles")
    for a, b, ha, hb in zip(cycles[:-1], cycles[1:], hc[:-1], hc[1:]):
        ax2.annotate(f"+{(hb - ha) * 100:.1f} cm", ((a + b) / 2, (ha + hb) / 2), fontsize=7, ha="right")
    ax2.axvspan(0, t_roll, color="0.93", label="hold (gravity on at 0.2 s)")
    ax2.set_xlabel("t s"), ax2.set_ylabel("climb m"), ax2.grid(True, lw=0.3)
    vd = ev["vertical_distance"]
    ax2.set_title(f"net {vd['net_m']:.2f} m in {t[-1] - t_roll:.0f} s of rolling at f = {f} Hz "
                  f"(rosenbrock_w, 2 ms)", fontsize=9)
    ax2.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{SCENE}.png"
    fig.savefig(path, dpi=110)
    print(json.dumps(ev, indent=1))
    print("per cycle (m):", np.round(np.diff(hc), 4).tolist())
    print("wrote", path)


if __name__ == "__main__":
    main()
