"""The viewer's default layout: the 3-D world beside the recorded signals' plots, the cameras' images
under the world."""

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


def default_blueprint(positions, series_paths, camera_paths=()):
    """The 3-D world (robot, terrain, sensor points and camera frusta) beside the plots; with cameras
    (their pinhole entities), a row of 2-D views, one per camera (image and depth), under the world."""
    import rerun.blueprint as rrb

    position, target = eye(positions)
    world = rrb.Spatial3DView(origin=E.WORLD, name="world",
                              eye_controls=rrb.EyeControls3D(position=position, look_target=target,
                                                             eye_up=[0.0, 0.0, 1.0]))
    plots = [rrb.TimeSeriesView(origin=p, name=p[len(E.PLOTS) + 1:]) for p in series_paths]
    plots.append(rrb.TimeSeriesView(origin=E.REAL_TIME_FACTOR, name="real-time factor"))
    left = world
    if camera_paths:
        cameras = [rrb.Spatial2DView(origin=p, name=_camera_name(p)) for p in camera_paths]
        left = rrb.Vertical(world, rrb.Horizontal(*cameras), row_shares=[2, 1])
    return rrb.Blueprint(rrb.Horizontal(left, rrb.Tabs(*plots), column_shares=[3, 2]), collapse_panels=True)


def _camera_name(pinhole_path: str) -> str:
    """'world/sensors/stereo/left/pinhole' -> 'stereo/left'."""
    return pinhole_path[len(E.SENSORS) + 1:].rsplit("/", 1)[0]
