"""The viewer's default layout: the 3-D world beside the recorded signals' plots."""

from __future__ import annotations

import numpy as np

from . import entities as E


def eye(positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(camera position, look target) framing points (n, 3) from the front-left, above."""
    pts = np.asarray(positions, dtype=float).reshape(-1, 3)
    target = pts.mean(axis=0)
    radius = float(np.max(np.linalg.norm(pts - target, axis=1), initial=0.0)) + 0.3
    d = max(1.2, 2.2 * radius)
    direction = np.array([0.35, -0.8, 0.5])
    return target + d * direction / np.linalg.norm(direction), target


def default_blueprint(positions, series_paths):
    import rerun.blueprint as rrb

    position, target = eye(positions)
    world = rrb.Spatial3DView(origin=E.WORLD, name="world",
                              eye_controls=rrb.EyeControls3D(position=position, look_target=target,
                                                             eye_up=[0.0, 0.0, 1.0]))
    plots = [rrb.TimeSeriesView(origin=p, name=p[len(E.PLOTS) + 1:]) for p in series_paths]
    plots.append(rrb.TimeSeriesView(origin=E.REAL_TIME_FACTOR, name="real-time factor"))
    return rrb.Blueprint(rrb.Horizontal(world, rrb.Tabs(*plots), column_shares=[3, 2]), collapse_panels=True)
