"""Writes what the perception sensors measured into a rerun recording: one sample, once, at its time.

The sink hands over the latest value of each sensor output it reads (``LidarScan`` or
``CameraFrame``, components/perception) every viewer frame; a sample is new when its
``(seq, t)`` differs from the one last logged for that output, so a sensor slower than the
viewer (5-20 Hz against ~30 Hz) is logged once per sample, at its own sample time ``t`` on
the ``sim`` timeline, not at the frame that noticed it. A sensor faster than the viewer
shows the sample the viewer finds at each frame.

Entities, for a sensor output 'comp.port' (:func:`.entities.sensor_path`)::

    world/sensors/<comp>/<port>                 Transform3D   the sensor pose at t, world: the lidar
                                                              frame, or the camera's optical frame
    .../<port>/points           (lidar)         Points3D      returns (status RETURN, finite) in the
                                                              lidar frame, m; colour = intensity through
                                                              a colormap over ``intensity_range``
    .../<port>/pinhole          (camera)        Pinhole       static: resolution, K, camera_xyz RDF (x
                                                              right, y down, z forward: the optical frame)
    .../<port>/pinhole/image    (camera)        Image         8-bit grey (h, w) or RGB (h, w, 3)
    .../<port>/pinhole/depth    (camera)        DepthImage    z in the optical frame, m (meter = 1);
                                                              0 where nothing was hit (rerun: no depth)

Images: the camera's values are linear radiance, unbounded (1 = white square-on to unit
irradiance). For display they are saturated to [0, 1] and scaled to uint8 (NaN -> 0);
no gamma is applied here (the ``gamma`` filter does that, upstream, when wanted).

K: a model whose ``camera_info()`` is a plain pinhole ("plumb_bob", no distortion) gives its
own K. Others (fisheye, CAHVOR, CAHVORE, a CAHV that is not a ROS pinhole) get the centred
pinhole with the model's horizontal and vertical fields of view (capped below 180°): the
frustum drawn spans what the camera sees, exactly at the middles of the image edges and to
first order elsewhere; the images themselves are the model's own pixels.
"""

from __future__ import annotations

import functools
import math
from typing import Sequence

import numpy as np

from . import entities as E

#: widest field of view (rad) a drawn frustum gets: a pinhole cannot show 180° or more
MAX_FRUSTUM_FOV = math.radians(170.0)


class SensorLog:
    """One recording's sensor entities.

    rec              rerun.RecordingStream
    outputs          the sensor outputs, 'comp.port', in the order :meth:`add` receives their values
    point_radius     m, radius of a lidar point
    intensity_range  (lo, hi): lidar intensities mapped onto the colormap (saturated outside)
    colormap         a matplotlib colormap name
    frustum_depth    m, distance of the drawn image plane from the camera (the frustum's length)
    """

    def __init__(self, rec, outputs: Sequence[str], *, point_radius: float = 0.01,
                 intensity_range: tuple[float, float] = (0.0, 1.0), colormap: str = "turbo",
                 frustum_depth: float = 0.3):
        import rerun as rr

        from snakesim.components.perception import CameraFrame, LidarScan

        self.rr, self.rec = rr, rec
        self._lidar, self._camera = LidarScan, CameraFrame
        self.outputs = list(outputs)
        self.paths = [E.sensor_path(o) for o in self.outputs]
        self.point_radius = float(point_radius)
        self.intensity_range = (float(intensity_range[0]), float(intensity_range[1]))
        self.lut = colormap_lut(colormap)
        self.frustum_depth = float(frustum_depth)
        self._last: list[tuple | None] = [None] * len(self.outputs)      # (seq, t) last logged
        self._models: list = [None] * len(self.outputs)                   # camera model of the pinhole logged

    def add(self, samples: Sequence) -> int:
        """Log each sample that is new since the last call (None: nothing yet); returns how many."""
        logged = 0
        for i, s in enumerate(samples):
            if s is None:
                continue
            key = (s.seq, s.t)
            if key == self._last[i]:
                continue
            self._last[i] = key
            self._log(i, s)
            logged += 1
        return logged

    def _log(self, i: int, sample) -> None:
        rr, rec, path = self.rr, self.rec, self.paths[i]
        if isinstance(sample, self._lidar):
            parts = [(E.SENSOR_POINTS, self.points(sample))]
        elif isinstance(sample, self._camera):
            self._pinhole(i, sample.model)
            parts = [(E.SENSOR_IMAGE, display_image(rr, sample.image)),
                     (E.SENSOR_DEPTH, rr.DepthImage(depth_for_display(sample.depth), meter=1.0))]
        else:
            raise TypeError(f"rerun_viewer: sensor '{self.outputs[i]}' gave a {type(sample).__name__}; "
                            "a sensor input takes a LidarScan or a CameraFrame")
        rec.set_time(E.TIMELINE, duration=float(sample.t))
        rec.log(path, pose_transform(rr, sample.pose))
        for sub, archetype in parts:
            rec.log(f"{path}/{sub}", archetype)
        rec.reset_time()          # the scene log sends with explicit times; leave no time set behind

    def points(self, scan):
        """Points3D of a scan's returns, lidar frame, coloured by intensity."""
        # a noisy range may still be a return; NaN rows never are
        ok = scan.returned & np.isfinite(scan.points).all(axis=1)
        lo, hi = self.intensity_range
        x = (np.asarray(scan.intensity[ok], dtype=np.float32) - lo) * (1.0 / (hi - lo))
        idx = (np.clip(x, 0.0, 1.0) * (len(self.lut) - 1) + 0.5).astype(np.intp)
        return self.rr.Points3D(scan.points[ok], colors=self.lut[idx], radii=self.point_radius)

    def _pinhole(self, i: int, model) -> None:
        """The camera's pinhole, static: logged at its first sample and again if its model changes."""
        last = self._models[i]
        if last is model or (last is not None and last == model):
            return
        self._models[i] = model
        rr = self.rr
        self.rec.log(f"{self.paths[i]}/{E.SENSOR_PINHOLE}",
                     rr.Pinhole(image_from_camera=intrinsics(model), resolution=[model.width, model.height],
                                camera_xyz=rr.ViewCoordinates.RDF, image_plane_distance=self.frustum_depth),
                     static=True)


def pose_transform(rr, pose):
    """Transform3D of [x, y, z, qx, qy, qz, qw] (the sensor frame in the world)."""
    p = np.asarray(pose, dtype=float)
    return rr.Transform3D(translation=p[:3], quaternion=rr.Quaternion(xyzw=p[3:7]))


def intrinsics(model) -> np.ndarray:
    """3×3 K (pixels; (0, 0) the top-left pixel's centre) drawn for a camera model: its own when it
    is a plain pinhole, else the centred pinhole with its fields of view (module docstring)."""
    info = model.camera_info()
    if info is not None and info.get("distortion_model") == "plumb_bob" and not any(info.get("d", ())):
        return np.reshape(np.asarray(info["k"], dtype=float), (3, 3))
    w, h = model.width, model.height
    fx = (w / 2) / math.tan(min(abs(model.horizontal_fov), MAX_FRUSTUM_FOV) / 2)
    fy = (h / 2) / math.tan(min(abs(model.vertical_fov), MAX_FRUSTUM_FOV) / 2)
    return np.array([[fx, 0.0, (w - 1) / 2], [0.0, fy, (h - 1) / 2], [0.0, 0.0, 1.0]])


def display_image(rr, image):
    """rr.Image of a linear float image: saturated to [0, 1], scaled to uint8; grey (h, w) or
    RGB (h, w, 3). Integer images are shown as they are."""
    a = np.asarray(image)
    if a.dtype.kind == "f":
        a = np.nan_to_num(a, nan=0.0, posinf=1.0, neginf=0.0)
        a = (np.clip(a, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    if a.ndim == 3 and a.shape[2] == 1:
        a = a[:, :, 0]
    return rr.Image(a, color_model="L" if a.ndim == 2 else "RGB")


def depth_for_display(depth) -> np.ndarray:
    """float32 depth, m, with 0 where there is none (NaN, inf): rerun's 'no depth'."""
    return np.nan_to_num(np.asarray(depth, dtype=np.float32), nan=0.0, posinf=0.0, neginf=0.0)


@functools.lru_cache(maxsize=8)
def colormap_lut(name: str) -> np.ndarray:
    """(256, 4) uint8 RGBA of a matplotlib colormap, built once per name."""
    import matplotlib

    lut = matplotlib.colormaps[name](np.linspace(0.0, 1.0, 256))
    lut = (lut * 255.0 + 0.5).astype(np.uint8)
    lut.setflags(write=False)
    return lut
