"""Lidar: ray-cast ranges and diffuse intensities from a frame on a robot link (paper 2.2.3).

At each sample (its ``rate``, Hz) every beam k (origin o_k, unit direction d_k, lidar frame;
see .beam_patterns) is cast in the world from the sensor pose (R_ws, p_ws; see .mount)
against the ``sensor_scene``'s physical objects: terrain and the robot's own links (a lidar
on the head sees the body behind it). The first surface along the beam at range r gives

    point_k     = o_k + r·d_k              lidar frame, m
    intensity_k = ρ·cos θ·(r_ref / r)²     ``raw`` (or ρ·cos θ, ``reflectivity``; .reflectance)

ρ the surface material's albedo, θ the incidence angle. Every beam keeps its slot (an
organised cloud for a grid); a beam without a valid return has NaN point and range,
intensity 0 and a status saying why:

    RETURN     0   a return at min_range <= r <= max_range
    NO_RETURN  1   nothing within max_range
    TOO_CLOSE  2   the first surface is nearer than min_range (it blocks the beam)
    DROPOUT    3   a return lost at random (probability ``dropout``)

Range noise (Gaussian, ``range_noise`` m) and dropouts are seeded (.sensors.noise: the
seed and the sample counter key the draw), so a run is reproducible. All beams of a sample
are cast at one instant (a spinning unit's sweep during its period is not modelled). Hits on
a curved analytic terrain (tube, moulin) are refined onto its exact surface
(``terrain_hits: exact``, the default: the geometry the contact model touches) or taken from
its tessellation (``mesh``: faster, off by up to the mesh's sag; bench/perception.py measures
both). The beams' hits on the mount link itself are cast once (.ray_caster.RayBundle).

in   world: RayCaster (from sensor_scene)
out  scan: LidarScan    (role LIDAR_SCAN)
     returns[1]         number of beams with a return (a plottable summary)
uses robot: RobotModel: the mount link
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

import numpy as np
from numba import njit
from pydantic import Field, model_validator

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.port_roles import LIDAR_SCAN
from snakesim.components.sensors.noise import noise_needs_rate
from snakesim.framework import Component, Input, Output, Params, Uses

from .beam_patterns import PRESETS, BeamFile, BeamGrid, BeamPattern, BeamRosette
from .mount import SensorMount, mount_on, quaternion_xyzw
from .ray_caster import CastBuffers, RayBundle
from .ray_casting import RayCaster
from .reflectance import lidar_intensity

RETURN, NO_RETURN, TOO_CLOSE, DROPOUT = 0, 1, 2, 3
STATUS_NAMES = ("return", "no_return", "too_close", "dropout")
#: rays start this far out (m): a lidar flush with its housing must not hit the housing at r = 0
SELF_HIT_GUARD = 1e-6


@dataclasses.dataclass(frozen=True)
class LidarScan:
    """One lidar sample. Arrays have one entry per beam, in pattern order.

    t s; ``frame`` the lidar's name; points (n, 3) float32 m lidar frame (NaN without a return);
    range (n,) float32 m (NaN without); intensity (n,) float32 (0 without); status (n,) uint8;
    ring (n,) uint16; ``shape`` (rows, columns) for an organised grid; ``pose`` (7,) the lidar
    frame in the world [x, y, z, qx, qy, qz, qw]; ``seq`` the sample number."""

    t: float
    frame: str
    points: np.ndarray
    range: np.ndarray
    intensity: np.ndarray
    status: np.ndarray
    ring: np.ndarray
    shape: tuple[int, int] | None
    pose: np.ndarray
    seq: int

    @property
    def returned(self) -> np.ndarray:
        return self.status == RETURN


class LidarParams(SensorMount, Params):
    link: str = Field("lidar", description="robot link the lidar is fixed to")
    preset: str | None = Field(None, description=f"beams and ranges of a known unit: {', '.join(PRESETS)}")
    beams: BeamGrid | BeamRosette | BeamFile | None = Field(
        None, discriminator="kind", description="beam pattern (kind: grid | rosette | file); overrides the preset's")
    min_range: float | None = Field(None, ge=0, description="m (default: the preset's, else 0.1)")
    max_range: float | None = Field(None, gt=0, description="m (default: the preset's, else 30)")
    range_noise: float = Field(0.0, ge=0, description="m, standard deviation of Gaussian range noise")
    dropout: float = Field(0.0, ge=0, lt=1, description="probability that a return is lost")
    intensity: Literal["raw", "reflectivity"] = Field("raw", description="raw: ρ cos θ (r_ref/r)²; "
                                                                        "reflectivity: ρ cos θ")
    reference_range: float = Field(1.0, gt=0, description="m, r_ref of the raw intensity")
    seed: int = Field(0, ge=0, description="noise and dropout seed")
    terrain_hits: Literal["exact", "mesh"] = Field(
        "exact", description="exact: hits on a curved analytic terrain (tube, moulin, ...) refined onto its "
                             "surface by Newton's method (the geometry the contact model touches); mesh: the "
                             "tessellation's hits (sensor_scene's cell), faster, off by up to its sag")
    name: str | None = Field(None, description="frame name in the outputs (default: the component's)")

    @model_validator(mode="after")
    def _known_preset(self):
        if self.preset is not None and self.preset not in PRESETS:
            raise ValueError(f"preset = '{self.preset}' is not a known lidar; valid: {', '.join(PRESETS)}")
        if self.preset is None and self.beams is None:
            raise ValueError(f"a lidar needs beams (kind: grid | rosette | file) or a preset ({', '.join(PRESETS)})")
        return self


class Lidar(Component[LidarParams]):
    type_name = "lidar"
    robot = Uses(RobotModel)

    world = Input(type=RayCaster)
    scan = Output(type=LidarScan, feedthrough=True, role=LIDAR_SCAN, doc="this sample's beams")
    returns = Output(shape=(1,), unit="1", feedthrough=True, doc="beams with a return")

    def setup(self):
        p = self.p
        preset = PRESETS.get(p.preset, {})
        spec = p.beams if p.beams is not None else preset["beams"]
        try:
            self.pattern: BeamPattern = spec.beams()
        except ValueError as e:
            raise ValueError(f"{self.name}: beams: {e}") from None
        self.min_range = p.min_range if p.min_range is not None else preset.get("min_range", 0.1)
        self.max_range = p.max_range if p.max_range is not None else preset.get("max_range", 30.0)
        if not self.min_range < self.max_range:
            raise ValueError(f"{self.name}: min_range = {self.min_range:g} m must be below "
                             f"max_range = {self.max_range:g} m")
        if self.rate is None:
            raise ValueError(f"{self.name}: a lidar samples at a rate: give the component a 'rate' (Hz) "
                             "in the assembly (e.g. rate: 10)")
        noise_needs_rate(self.name, self.rate, p.range_noise, p.dropout)
        self.row, self.R_ls, self.p_ls = mount_on(self.robot, p, self.name)
        self.frame_id = p.name or self.name
        # beams cast in pattern order: neighbouring beams meet the same parts of the scene, and
        # Embree runs faster on such rays (a 64x1024 frame: 6.8 ms against 9.9 ms with the beams
        # dealt out to the chunks in turn, .ray_caster.interleaved, as cameras do)
        self.order = np.arange(len(self.pattern.directions))
        self.cast_o = np.ascontiguousarray(self.pattern.origins[self.order])
        self.cast_d = np.ascontiguousarray(self.pattern.directions[self.order])
        # binned once; fixed to its link: the beams' hits on that link (the housing) are cast once
        self.bundle = RayBundle(self.cast_o, self.cast_d, mount=(self.row, self.R_ls, self.p_ls))
        self.buffers = CastBuffers(len(self.cast_d))                  # reused every sample
        self.ring = self.pattern.ring.astype(np.uint16)
        self.ring.flags.writeable = False          # one array shared by every scan

    def discrete_state(self):
        return np.zeros(1)       # sample counter: keys the noise draws

    def output(self, t, x, u, y):
        scan = self.sample(u.world, t, int(x[0]))
        y.scan = scan
        y.returns[0] = np.count_nonzero(scan.status == RETURN)

    def update(self, t, xd, u):
        xd[0] += 1.0

    def sample(self, world: RayCaster, t: float, seq: int) -> LidarScan:
        p, pat = self.p, self.pattern
        R_wl, p_wl = world.link_pose(self.row)
        R = R_wl @ self.R_ls
        origin = p_wl + R_wl @ self.p_ls
        # hits nearer than min_range only block (TOO_CLOSE): refined only as far as telling so
        hits, _, d_w = world.cast_from(R, origin, self.cast_o, self.cast_d, self.max_range, SELF_HIT_GUARD,
                                       self.bundle, self.buffers, p.terrain_hits == "exact", self.min_range)
        n = len(hits.distance)
        status, measured, intensity = np.empty(n, dtype=np.uint8), np.empty(n), np.empty(n, dtype=np.float32)
        points = np.empty((n, 3), dtype=np.float32)
        _returns(self.order, hits.distance, hits.normal, hits.albedo, d_w, self.min_range, p.reference_range,
                 p.intensity == "reflectivity", pat.origins, pat.directions, status, measured, intensity, points)
        if p.range_noise > 0 or p.dropout > 0:
            ret = status == RETURN
            gen = np.random.Generator(np.random.Philox(key=int(p.seed), counter=[seq, 0, 0, 0]))
            if p.range_noise > 0:
                measured = measured + p.range_noise * gen.standard_normal(n)
            if p.dropout > 0:
                lost = ret & (gen.random(n) < p.dropout)
                status[lost] = DROPOUT
                ret &= ~lost
                measured[lost] = np.nan
                intensity[lost] = 0.0
            _points(pat.origins, pat.directions, measured, points)        # at the noisy ranges
        pose = np.r_[origin, quaternion_xyzw(R)]
        return LidarScan(t, self.frame_id, points, measured.astype(np.float32), intensity, status, self.ring,
                         pat.shape, pose, seq)


@njit(cache=True, nogil=True)
def _returns(beam, distance, normal, albedo, d_w, min_range, reference_range, compensated, origins, directions,
             status, measured, intensity, points):
    """Per cast ray k (beam ``beam[k]``, pattern order in the outputs): status, measured range (NaN
    without a return), diffuse intensity (0 without; the rows of a miss in normal and albedo are
    unset and never read) and the point o + r·d (as ``_points``)."""
    for k in range(distance.shape[0]):
        i = beam[k]
        r = distance[k]
        if not math.isfinite(r):
            status[i], measured[i], intensity[i] = NO_RETURN, math.nan, 0.0
        elif r < min_range:
            status[i], measured[i], intensity[i] = TOO_CLOSE, math.nan, 0.0
        else:
            cos = max(-(normal[k, 0] * d_w[k, 0] + normal[k, 1] * d_w[k, 1] + normal[k, 2] * d_w[k, 2]), 0.0)
            status[i], measured[i] = RETURN, r
            intensity[i] = lidar_intensity(albedo[k], cos, r, reference_range, compensated)
        for a in range(3):
            points[i, a] = origins[i, a] + measured[i] * directions[i, a]


@njit(cache=True, nogil=True)
def _points(origins, directions, measured, points):
    """points = o + r·d (lidar frame, float32; NaN rows where r is NaN)."""
    for i in range(origins.shape[0]):
        for a in range(3):
            points[i, a] = origins[i, a] + measured[i] * directions[i, a]
