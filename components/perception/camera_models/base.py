"""The interface every camera model keeps, and the array helpers they share.

Frames and pixels (see the package docstring): points and rays are in the
sensor's optical frame (x right, y down, z forward), pixel (u, v) = (column,
row) with pixel centres at integers and (0, 0) the centre of the top-left
pixel, so the image spans [-0.5, width - 0.5] × [-0.5, height - 0.5].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def check_image_size(width, height) -> None:
    for key, value in (("width", width), ("height", height)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
            raise ValueError(f"{key} = {value!r}: must be a positive integer (pixels)")


def check_finite(**values) -> None:
    """Raise naming the first parameter that holds NaN or inf."""
    for key, value in values.items():
        if not np.all(np.isfinite(np.asarray(value, dtype=np.float64))):
            raise ValueError(f"{key} = {value!r}: must be finite (no NaN or inf)")


def as_points(points) -> np.ndarray:
    p = np.atleast_2d(np.asarray(points, dtype=np.float64))
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {np.shape(points)}")
    return p


def as_pixels(uv) -> np.ndarray:
    q = np.atleast_2d(np.asarray(uv, dtype=np.float64))
    if q.ndim != 2 or q.shape[1] != 2:
        raise ValueError(f"pixel coordinates must have shape (n, 2), got {np.shape(uv)}")
    return q


def unit(vectors: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return vectors / np.linalg.norm(vectors, axis=-1, keepdims=True)


@dataclass(frozen=True)
class CameraModel:
    """A camera's map between the sensor frame and pixels; subclasses define the maps.

    ``project`` and ``unproject`` are vectorised over rows; invalid rows carry NaN
    (pixels of points outside the model's domain, rays of pixels that no direction
    reaches, e.g. a fisheye's pixels past θ = 180° or a distortion's pixels past its fold).
    """

    width: int
    height: int

    def __post_init__(self):
        check_image_size(self.width, self.height)

    # --- the model: subclasses override these ---------------------------------------------
    def project(self, points) -> tuple[np.ndarray, np.ndarray]:
        """(n, 3) sensor-frame points -> (uv (n, 2) pixels, valid (n,)); NaN pixels where invalid.

        Pixels are not clipped to the image (see ``in_image``).
        """
        raise NotImplementedError

    def unproject(self, uv) -> tuple[np.ndarray, np.ndarray]:
        """(n, 2) pixels -> (origins (n, 3), unit directions (n, 3)), sensor frame; NaN where no ray."""
        raise NotImplementedError

    @property
    def axis(self) -> np.ndarray:
        """Unit optical axis in the sensor frame (the reference for the fields of view)."""
        return np.array([0.0, 0.0, 1.0])

    def camera_info(self) -> dict | None:
        """sensor_msgs/CameraInfo fields {distortion_model, d, k, r, p}, or None if ROS has no equivalent."""
        return None

    # --- shared on top of the model ---------------------------------------------------------
    def in_image(self, uv) -> np.ndarray:
        """(n,) bool: the pixel coordinates fall on the image (pixel edges at ±0.5 of the centres)."""
        q = as_pixels(uv)
        u, v = q[:, 0], q[:, 1]
        return (u >= -0.5) & (u < self.width - 0.5) & (v >= -0.5) & (v < self.height - 0.5)

    def pixel_rays(self) -> tuple[np.ndarray, np.ndarray]:
        """Rays through every pixel centre: (origins (h, w, 3), directions (h, w, 3))."""
        v, u = np.mgrid[0 : self.height, 0 : self.width]
        uv = np.stack([u.ravel(), v.ravel()], axis=1).astype(np.float64)
        origins, directions = self.unproject(uv)
        shape = (self.height, self.width, 3)
        return origins.reshape(shape), directions.reshape(shape)

    def corner_rays(self) -> tuple[np.ndarray, np.ndarray]:
        """Rays through the image's outer corners (pixel edges), for drawing a frustum.

        Order: top-left, top-right, bottom-right, bottom-left; (4, 3) origins and directions.
        """
        right, bottom = self.width - 0.5, self.height - 0.5
        return self.unproject([[-0.5, -0.5], [right, -0.5], [right, bottom], [-0.5, bottom]])

    @property
    def horizontal_fov(self) -> float:
        """Radians between the rays through the left and right image edges, across the middle row.

        Measured as signed angles about the optical axis, so a fisheye's may exceed π.
        """
        middle = (self.height - 1) / 2
        return self._fov_across((-0.5, middle), (self.width - 0.5, middle))

    @property
    def vertical_fov(self) -> float:
        """Radians between the rays through the top and bottom image edges, down the middle column."""
        middle = (self.width - 1) / 2
        return self._fov_across((middle, -0.5), (middle, self.height - 0.5))

    def _fov_across(self, start, end) -> float:
        # The direction "across" comes from the rays either side of the image centre, not from the
        # edge rays themselves, which are nearly antiparallel for a fisheye of about 360°.
        centre = np.array([(self.width - 1) / 2, (self.height - 1) / 2])
        step = np.subtract(end, start) / np.linalg.norm(np.subtract(end, start))
        _, near = self.unproject([centre - step, centre + step])
        _, edges = self.unproject([start, end])
        axis = self.axis
        across = near[1] - near[0]
        across = across - (across @ axis) * axis
        across /= np.linalg.norm(across)
        angles = np.arctan2(edges @ across, edges @ axis)
        return float(angles[1] - angles[0])


def pinhole_camera_info(distortion_model: str, d: list[float], fx, fy, cx, cy) -> dict:
    """CameraInfo fields for an unrectified camera whose rectified image is itself: R = I, P = [K | 0]."""
    k = [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]
    p = [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]
    r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    return {
        "distortion_model": distortion_model,
        "d": [float(x) for x in d],
        "k": [float(x) for x in k],
        "r": r,
        "p": [float(x) for x in p],
    }


def degrees_in(key: str, value: float, low: float, high: float, high_inclusive: bool, hint: str = "") -> float:
    """value (degrees) checked to lie in (low, high) or (low, high]; returned in radians."""
    ok = value > low and (value <= high if high_inclusive else value < high)
    if not (math.isfinite(value) and ok):
        bracket = "]" if high_inclusive else ")"
        raise ValueError(f"{key} = {value!r}: must be in ({low:g}, {high:g}{bracket} degrees{hint}")
    return math.radians(value)
