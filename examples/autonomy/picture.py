"""A PNG of the node's cost map, its planned path and the head's driven track (matplotlib, no display)."""

import numpy as np


def write_picture(path: str, cost_map, planned, track, goal) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    p = cost_map.p
    cost = cost_map.cost()
    shown = np.where(np.isfinite(cost), cost, np.nan)
    fig, ax = plt.subplots(figsize=(10, 5))
    ax.imshow(shown.T, origin="lower", extent=(p.x0, p.x1, p.y0, p.y1), cmap="Greys", alpha=0.6)
    lethal = ~np.isfinite(cost)
    ax.contourf(*np.meshgrid(np.linspace(p.x0, p.x1, cost.shape[0]), np.linspace(p.y0, p.y1, cost.shape[1]),
                             indexing="ij"), lethal.astype(float), levels=[0.5, 1.5], colors=["tab:red"], alpha=0.35)
    ob = cost_map.obstacles()
    xy = cost_map.center(*np.nonzero(ob))
    ax.plot(xy[:, 0], xy[:, 1], "s", ms=1.5, color="k", label="obstacle cells (lidar)")
    if planned is not None:
        ax.plot(planned[:, 0], planned[:, 1], "-", color="tab:blue", label="planned path (last)")
    if len(track):
        ax.plot(track[:, 0], track[:, 1], "-", color="tab:green", label="head, driven")
    ax.add_patch(plt.Circle(goal, 0.6, fill=False, color="tab:orange", label="goal region"))
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
