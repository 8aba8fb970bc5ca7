"""Cameras: ray-cast depth and shaded images from a frame on a robot link (paper 2.2.3, fig. 7).

Each pixel (u, v) of the camera model (.camera_models: pinhole, fisheye, CAHV, CAHVOR,
CAHVORE; ``unproject`` of its centre) is a ray from the optical frame, turned into the
world by the sensor pose (.mount; ``optical: true`` turns a body-convention link frame,
x forward, into the optical frame, z forward). The ray is cast against the
``sensor_scene``'s physical objects; the first surface at range r along the ray gives

    range  r                                   m, along the ray
    depth  z of the hit in the optical frame   m (a ROS depth image's value)
    image  ρ·(ambient + E·cos θ)               .reflectance: ρ the albedo (grey) or colour (RGB)
                                               of the material; E the light's irradiance: a
                                               ``sun`` (optional shadow rays) or a ``headlamp``
                                               at the camera (falls off as 1/r²)
    label  what the pixel's ray hit            .labels: nothing, terrain material, robot link,
                                               obstacle (uint16)

Pixels whose ray hits nothing within max_range have NaN range and depth, label 0 and the
``background`` value. ``texture_contrast`` scales the terrain materials' texture contrasts
(0: featureless ice, what defeats visual odometry; 1: as the materials say). Image values
are linear radiance, unbounded (1 = a white surface square-on to unit irradiance); the
filters after a camera (.filters) add noise, vignetting, gamma and colour, and an 8-bit sink
saturates at 1.

``camera``         one view:     out ``frame``
``stereo_camera``  a synchronised pair, the right camera ``baseline`` m along the left's
                   optical +x:   out ``left``, ``right``

in   world: RayCaster (from sensor_scene)
out  CameraFrame (role CAMERA_FRAME) per view, at the component's rate
uses robot: RobotModel: the mount link
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field, field_validator

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.port_roles import CAMERA_FRAME
from snakesim.framework import Component, Input, Output, Params, Uses

from .camera_models import CameraModel, camera_model_from_spec
from .mount import SensorMount, mount_on, quaternion_xyzw
from .ray_caster import CastBuffers, RayBundle, in_chunks, interleaved
from .ray_casting import RayCaster
from .hit_kernels import develop
from .labels import LABEL_DTYPE, NOTHING, labels_of

Vec3 = tuple[float, float, float]
#: shadow rays start this far off the surface (m), so a surface does not shadow itself
SHADOW_OFFSET = 1e-4
#: bytes a camera holds a pixel whatever it renders: its rays (the model's, in cast order, contiguous
#: copies: 2 x 48), indices (16), the binned bundle (~16) and the reused cast buffers (CastBuffers: ~190, with
#: the labels)
RAY_BYTES_PER_PIXEL = 322


def frame_bytes_per_pixel(color: bool) -> int:
    """Bytes a rendered frame takes a pixel: image (grey float32, or RGB), range, depth, shadow mask, label."""
    return (12 if color else 4) + 4 + 4 + 1 + 2


def camera_memory_bytes(width: int, height: int, views: int = 1, color: bool = False) -> float:
    """What a camera of ``width`` x ``height`` pixels allocates: ray and cast buffers once, a frame per view."""
    return float(width) * float(height) * (RAY_BYTES_PER_PIXEL + views * frame_bytes_per_pixel(color))


def check_camera_size(width: int, height: int, views: int = 1, color: bool = False) -> None:
    """A ValueError with the estimate and the largest size at this aspect ratio that fits, before anything is
    allocated, when the camera would pass the memory limit (framework/limits.py)."""
    from snakesim.framework.limits import fmt_bytes, memory_limit_bytes

    need, limit = camera_memory_bytes(width, height, views, color), memory_limit_bytes()
    if need <= limit:
        return
    per_px = need / (float(width) * float(height))
    scale = (limit / need) ** 0.5
    fit_w, fit_h = max(1, int(width * scale)), max(1, int(height * scale))
    raise ValueError(f"{width}x{height} pixels would take ~{fmt_bytes(need)} ({per_px:.0f} B a pixel: the rays and "
                     f"cast buffers {RAY_BYTES_PER_PIXEL} B, and {views} frame(s) of "
                     f"{frame_bytes_per_pixel(color)} B), over the memory limit {fmt_bytes(limit)} (half the "
                     f"physical memory, or SNAKESIM_MEMORY_LIMIT); at most ~{int(limit // per_px)} pixels fit, "
                     f"e.g. {fit_w}x{fit_h}")


@dataclasses.dataclass(frozen=True)
class CameraFrame:
    """One camera image. t s; ``frame`` the camera's optical frame name; ``model`` its
    CameraModel; image (h, w) grey or (h, w, 3) linear RGB float32; depth and range (h, w)
    float32 m (NaN where nothing is hit); pose (7,) the optical frame in the world
    [x, y, z, qx, qy, qz, qw]; ``seq`` the sample number; label (h, w) uint16 what each pixel's
    ray hit (.labels, 0 for nothing)."""

    t: float
    frame: str
    model: CameraModel
    image: np.ndarray
    depth: np.ndarray
    range: np.ndarray
    pose: np.ndarray
    seq: int
    label: np.ndarray | None = None

    def with_image(self, image: np.ndarray) -> "CameraFrame":
        """This frame with another image (what a filter returns)."""
        return dataclasses.replace(self, image=image)


class Light(Params):
    """The scene's light as the camera sees it."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    kind: Literal["headlamp", "sun"] = Field("headlamp", description="headlamp: at the camera, along its "
                                                                      "rays (subsurface); sun: parallel rays")
    direction: Vec3 = Field((0.3, 0.2, -1.0), description="sun: direction the light travels, world")
    intensity: float = Field(1.0, ge=0, description="irradiance E (headlamp: at reference_range)")
    ambient: float = Field(0.05, ge=0, description="irradiance reaching every surface")
    reference_range: float = Field(1.0, gt=0, description="m, headlamp: range of irradiance E")
    shadows: bool = Field(False, description="sun: cast shadow rays (doubles the rays)")

    @field_validator("direction")
    @classmethod
    def _direction(cls, v):
        if not (np.all(np.isfinite(v)) and np.linalg.norm(v) > 0):
            raise ValueError(f"direction = {list(v)} must be a finite non-zero vector")
        return v


class CameraParams(SensorMount, Params):
    link: str = Field("camera_left", description="robot link the camera is fixed to")
    optical: bool = Field(True, description="the mount frame is body-convention (x forward): turn it to "
                                            "the optical frame (z forward, x right, y down)")
    width: int = Field(640, ge=1, description="pixels")
    height: int = Field(480, ge=1, description="pixels")
    model: dict = Field(default_factory=lambda: {"kind": "pinhole", "fov": 90.0},
                        description="camera model (kind: pinhole | fisheye | cahv | cahvor | cahvore, "
                                    "and its parameters; see camera_models)")
    color: bool = Field(False, description="RGB image from material colours (else grey from albedo)")
    light: Light = Field(default_factory=Light)
    near: float = Field(0.01, ge=0, description="m, nothing nearer is seen (rays start here)")
    max_range: float = Field(100.0, gt=0, description="m, nothing farther is seen")
    background: float = Field(0.0, ge=0, description="image value where nothing is hit")
    texture_contrast: float = Field(1.0, ge=0, le=1, description="terrain materials' texture contrasts times "
                                                                  "this (0: featureless)")
    terrain_hits: Literal["exact", "mesh"] = Field(
        "exact", description="exact: hits on a curved analytic terrain refined onto its surface (Newton); "
                             "mesh: the tessellation's hits (sensor_scene's cell), faster")
    name: str | None = Field(None, description="frame name in the outputs (default: the component's)")


class StereoCameraParams(CameraParams):
    baseline: float = Field(0.0675, gt=0, description="m, right camera along the left's optical +x")


class _Camera(Component):
    robot = Uses(RobotModel)
    world = Input(type=RayCaster)

    def setup(self):
        p = self.p
        if self.rate is None:
            raise ValueError(f"{self.name}: a camera samples at a rate: give the component a 'rate' (Hz) "
                             "in the assembly (e.g. rate: 5)")
        if not p.near < p.max_range:
            raise ValueError(f"{self.name}: near = {p.near:g} m must be below max_range = {p.max_range:g} m")
        try:        # before any pixel is allocated
            check_camera_size(p.width, p.height, 2 if isinstance(self, StereoCamera) else 1, p.color)
        except ValueError as e:
            raise ValueError(f"{self.name}: {e}") from None
        self.model = camera_model_from_spec(p.model, p.width, p.height, where=f"{self.name}: model")
        o, d = self.model.pixel_rays()
        o, d = o.reshape(-1, 3), d.reshape(-1, 3)
        # pixels without a ray (a 360° fisheye's corners, past a distortion's fold) stay background;
        # the rest in the cast order that gives each thread rays from the whole image
        self._rays = np.flatnonzero(np.isfinite(d).all(axis=1) & np.isfinite(o).all(axis=1))
        self._rays = self._rays[interleaved(len(self._rays))]
        self._o, self._d = np.ascontiguousarray(o[self._rays]), np.ascontiguousarray(d[self._rays])
        # the rays' optical-frame z (a depth's), contiguous: a render reads them per pixel
        self._oz, self._dz = self._o[:, 2].copy(), self._d[:, 2].copy()
        # every ray writes its pixel, hit or not (develop): only the pixels without a ray are filled apart
        self._unrayed = np.setdiff1d(np.arange(p.width * p.height), self._rays)
        self._unshadowed = np.zeros(len(self._d), dtype=np.bool_)      # read-only use: no shadow rays
        self._bundle = RayBundle(self._o, self._d)             # binned once: finds the rays near the robot
        self._bundle.image = (p.width, p.height, self._rays)   # which pixel each ray is: a back end may rasterise
        self._buffers = CastBuffers(len(self._d))              # reused by every render (hits are used at once)
        self.row, self.R_ls, self.p_ls = mount_on(self.robot, p, self.name, optical=p.optical)
        self.frame_id = p.name or self.name
        light = p.light
        self._sun = -np.asarray(light.direction, dtype=float) / np.linalg.norm(light.direction)

    def discrete_state(self):
        return np.zeros(1)       # sample counter

    def update(self, t, xd, u):
        xd[0] += 1.0

    def pose(self, world: RayCaster, offset=(0.0, 0.0, 0.0)):
        """(R_wc, p_wc) of the optical frame, moved by ``offset`` m along its own axes."""
        R_wl, p_wl = world.link_pose(self.row)
        R = R_wl @ self.R_ls
        return R, p_wl + R_wl @ self.p_ls + R @ np.asarray(offset, dtype=float)

    def render(self, world: RayCaster, R: np.ndarray, p_w: np.ndarray, t: float, seq: int,
               frame: str) -> CameraFrame:
        prm, light = self.p, self.p.light
        h, w = prm.height, prm.width
        extra = {} if prm.texture_contrast == 1.0 else {"texture_contrast": prm.texture_contrast}
        hits, o_w, d_w = world.cast_from(R, p_w, self._o, self._d, prm.max_range, prm.near, self._bundle,
                                            self._buffers, prm.terrain_hits == "exact", **extra)
        headlamp = light.kind == "headlamp"
        shadowed = self._unshadowed
        if not headlamp and light.shadows:
            shadowed = np.zeros(len(d_w), dtype=np.bool_)
            hit = np.flatnonzero(np.isfinite(hits.distance))
            lit = hit[hits.normal[hit] @ self._sun > 0]
            p_hit = o_w[lit] + hits.distance[lit, None] * d_w[lit] + SHADOW_OFFSET * hits.normal[lit]
            shadowed[lit] = world.cast(p_hit, np.broadcast_to(self._sun, p_hit.shape), prm.max_range).hit
        channels = 3 if prm.color else 1
        # fresh arrays (the frame outlives this step), written once each: by develop, pixel by pixel
        image = np.empty((h * w, channels), dtype=np.float32)
        rng, depth = np.empty(h * w, dtype=np.float32), np.empty(h * w, dtype=np.float32)
        label = np.empty(h * w, dtype=LABEL_DTYPE)
        if len(self._unrayed):
            image[self._unrayed], rng[self._unrayed], depth[self._unrayed] = prm.background, np.nan, np.nan
            label[self._unrayed] = NOTHING
        ray_label = labels_of(hits)
        reflect = hits.color if prm.color else hits.albedo[:, None]

        def pixels(c, k):
            develop(self._rays[k], self._oz[k], self._dz[k], d_w[k], hits.distance[k], hits.normal[k],
                    reflect[k], headlamp, self._sun, light.intensity, light.ambient, light.reference_range,
                    shadowed[k], ray_label[k], prm.background, image, depth, rng, label)

        in_chunks(pixels, len(d_w))
        img = image.reshape(h, w, channels)
        return CameraFrame(t, frame, self.model, img if prm.color else img[:, :, 0], depth.reshape(h, w),
                           rng.reshape(h, w), np.r_[p_w, quaternion_xyzw(R)], seq, label.reshape(h, w))


class Camera(_Camera, Component[CameraParams]):
    type_name = "camera"
    frame = Output(type=CameraFrame, feedthrough=True, role=CAMERA_FRAME, doc="this sample's image")

    def output(self, t, x, u, y):
        R, p = self.pose(u.world)
        y.frame = self.render(u.world, R, p, t, int(x[0]), self.frame_id)


class StereoCamera(_Camera, Component[StereoCameraParams]):
    type_name = "stereo_camera"
    left = Output(type=CameraFrame, feedthrough=True, role=CAMERA_FRAME, doc="left image")
    right = Output(type=CameraFrame, feedthrough=True, role=CAMERA_FRAME, doc="right image, baseline m to the right")

    def output(self, t, x, u, y):
        seq = int(x[0])
        R, p = self.pose(u.world)
        y.left = self.render(u.world, R, p, t, seq, f"{self.frame_id}/left")
        R, p = self.pose(u.world, (self.p.baseline, 0.0, 0.0))
        y.right = self.render(u.world, R, p, t, seq, f"{self.frame_id}/right")
