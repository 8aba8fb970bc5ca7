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
    DROPOUT    3   lost at random: a return (probability ``dropout``), or every beam of a lost
                   packet (``packet_loss``)
    WEAK       4   a return too weak after the medium's attenuation (``detection_threshold``)

Every beam also carries ``label``, what it hit (.labels: nothing, terrain material, robot link,
obstacle; a beam without a return keeps the label of the surface it met, if any), and ``time``,
when it fired, s relative to the sample's stamp t (as Ouster's and Velodyne's drivers' per-point
time): a spinning unit turns once per period T = 1/rate and fires beam k at t − (1 − s_k)·T, s_k
its firing fraction (.beam_patterns: a grid's column at azimuth a at ((π − a) mod 2π)/2π, the sweep
starting behind and turning clockwise, ending at the stamp). With ``motion_distortion`` (default:
on for a grid, a spinning unit; off for a rosette or file) each beam is cast from the lidar's pose
at its own instant, interpolated between the previous sample and this one (.motion), and its point
is in the lidar frame of that instant: a moving lidar's scan is skewed as a real one's is (deskew
with ``time``). Off, every beam is cast at the stamp and ``time`` is 0. The first sample has no
previous pose: it is cast at one instant.

Degradations, seeded (.sensors.noise: the seed and the sample counter key the draws, in this
order: range noise, dropouts, packets), so a run is reproducible:

    range noise    Gaussian, σ(r) = range_noise + range_noise_slope·r (m; dust or fog: noise that
                   grows with range)
    attenuation    α (1/m) of a medium (dust, fog, blowing snow): the intensity times exp(−2αr)
                   (there and back); a return whose raw received intensity ρ cos θ (r_ref/r)²
                   exp(−2αr) is below ``detection_threshold`` is lost (WEAK)
    dropout        each return lost with probability ``dropout``
    packet_loss    the period is sent in ``packets`` packets (beams by firing time; a grid of 1024
                   columns in 64 packets: 16 columns each, as Ouster's); each is lost whole with
                   probability ``packet_loss`` (bursts)
    texture_contrast  the terrain materials' texture contrasts times this (0: featureless ice)

The robot's links, which move with the lidar, are cast along the nominal beams from the pose at the
stamp (their motion against the lidar within a period is neglected); the terrain along the moved
ones (.ray_caster's ``RayBundle.for_moved``).

Hits on a curved analytic terrain (tube, moulin) or a DEM are refined onto its exact surface
(``terrain_hits: exact``, the default: the geometry the contact model touches; a DEM's is
bilinear) or taken from its tessellation (``mesh``: faster, off along the beam by up to
sag/sin θ, θ the grazing angle: centimetres for a beam along a tube's axis; docs/perception.md,
bench/perception.py measures both). The beams' hits on the mount link itself are cast once (.ray_caster.RayBundle).

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

from snakesim.components.multibody.pose_quaternions import rotation_matrices

from .beam_patterns import PRESETS, BeamFile, BeamGrid, BeamPattern, BeamRosette
from .labels import LABEL_DTYPE, labels_of
from .motion import move_rays, relative_motion
from .mount import SensorMount, mount_on, quaternion_xyzw, rigid_links
from .ray_caster import CastBuffers, RayBundle
from .ray_casting import RayCaster
from .reflectance import lidar_intensity

RETURN, NO_RETURN, TOO_CLOSE, DROPOUT, WEAK = 0, 1, 2, 3, 4
STATUS_NAMES = ("return", "no_return", "too_close", "dropout", "weak")
#: rays start this far out (m): a lidar flush with its housing must not hit the housing at r = 0
SELF_HIT_GUARD = 1e-6


@dataclasses.dataclass(frozen=True)
class LidarScan:
    """One lidar sample. Arrays have one entry per beam, in pattern order.

    t s; ``frame`` the lidar's name; points (n, 3) float32 m lidar frame (NaN without a return);
    range (n,) float32 m (NaN without); intensity (n,) float32 (0 without); status (n,) uint8;
    ring (n,) uint16; ``shape`` (rows, columns) for an organised grid; ``pose`` (7,) the lidar
    frame in the world [x, y, z, qx, qy, qz, qw] at t; ``seq`` the sample number; label (n,) uint16
    what each beam hit (.labels); time (n,) float32 s when each beam fired, relative to t (<= 0)."""

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
    label: np.ndarray | None = None
    time: np.ndarray | None = None

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
    range_noise_slope: float = Field(0.0, ge=0, description="1, growth of the range noise's σ with range: "
                                                             "σ(r) = range_noise + range_noise_slope·r (dust, fog)")
    attenuation: float = Field(0.0, ge=0, description="1/m, α of the medium: intensity times exp(−2αr)")
    detection_threshold: float = Field(0.0, ge=0, description="raw received intensity ρ cos θ (r_ref/r)² "
                                                               "exp(−2αr) below which a return is lost (WEAK)")
    packet_loss: float = Field(0.0, ge=0, lt=1, description="probability that a packet (1/packets of the "
                                                             "period's beams, by firing time) is lost whole")
    packets: int = Field(64, ge=1, description="packets per period (packet_loss)")
    texture_contrast: float = Field(1.0, ge=0, le=1, description="terrain materials' texture contrasts times "
                                                                  "this (0: featureless)")
    motion_distortion: bool | None = Field(
        None, description="cast each beam from the lidar's pose at its firing time (default: on for a grid, "
                          "a spinning unit; off for a rosette or file)")
    seed: int = Field(0, ge=0, description="noise, dropout and packet-loss seed")
    terrain_hits: Literal["exact", "mesh"] = Field(
        "exact", description="exact: hits on a curved analytic terrain (tube, moulin, ...) refined onto its "
                             "surface by Newton's method (the geometry the contact model touches); mesh: the "
                             "tessellation's hits (sensor_scene's cell), faster, off along the beam by up to "
                             "its sag / sin(grazing angle)")
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
        noise_needs_rate(self.name, self.rate, p.range_noise, p.dropout, p.range_noise_slope, p.packet_loss)
        self.row, self.R_ls, self.p_ls = mount_on(self.robot, p, self.name)
        self.frame_id = p.name or self.name
        # beams cast in pattern order: neighbouring beams meet the same parts of the scene, and
        # Embree runs faster on such rays (a 64x1024 frame: 6.8 ms against 9.9 ms with the beams
        # dealt out to the chunks in turn, .ray_caster.interleaved, as cameras do)
        self.order = np.arange(len(self.pattern.directions))
        self.cast_o = np.ascontiguousarray(self.pattern.origins[self.order])
        self.cast_d = np.ascontiguousarray(self.pattern.directions[self.order])
        # binned once; fixed to its link: the beams' hits on that link (the housing) are cast once
        # (and on the links fixed to it: the head around it, cast once too while they stay in place)
        self.bundle = RayBundle(self.cast_o, self.cast_d, mount=(self.row, self.R_ls, self.p_ls),
                                rigid=rigid_links(self.robot, self.row))
        self.buffers = CastBuffers(len(self.cast_d))                  # reused every sample
        self.ring = self.pattern.ring.astype(np.uint16)
        self.ring.flags.writeable = False          # one array shared by every scan
        self._timing(p)

    def _timing(self, p: LidarParams) -> None:
        """Firing times (module docstring): each beam's slot among the distinct times, its time relative to
        the stamp (one read-only array shared by every scan) and its packet."""
        fire = self.pattern.fire
        self.distorted = p.motion_distortion if p.motion_distortion is not None else (
            isinstance(p.beams if p.beams is not None else PRESETS[p.preset]["beams"], BeamGrid))
        if self.distorted and fire is None:
            raise ValueError(f"{self.name}: motion_distortion needs the beams' firing times, which a beam file "
                             "does not give; set motion_distortion: false")
        n, period = len(self.pattern), 1.0 / self.rate
        fraction = fire[self.order] if fire is not None else np.ones(n)
        self.fire_back, slot = np.unique(1.0 - fraction, return_inverse=True)     # (1 − s) per distinct time
        self.fire_slot = slot.astype(np.int64)
        self.time = (-(1.0 - fraction) * period if self.distorted else np.zeros(n)).astype(np.float32)
        self.time.flags.writeable = False
        self.packet = np.minimum((np.mod(fraction, 1.0) * p.packets).astype(np.int64), p.packets - 1)
        if self.distorted:           # the moved rays, reused every sample, and the bundle that stands for them
            self.moved_o, self.moved_d = np.empty_like(self.cast_o), np.empty_like(self.cast_d)
            self.moved_bundle = self.bundle.for_moved(self.moved_d)

    def discrete_state(self):
        # sample counter (keys the noise draws); with motion distortion the mount link's pose at the last
        # sample: [counter, have-pose flag, t, x, y, z, qx, qy, qz, qw]
        return np.zeros(10) if self.distorted else np.zeros(1)

    def output(self, t, x, u, y):
        previous = (float(x[2]), x[3:6], x[6:10]) if self.distorted and x[1] > 0 else None
        scan = self.sample(u.world, t, int(x[0]), previous)
        y.scan = scan
        y.returns[0] = np.count_nonzero(scan.status == RETURN)

    def update(self, t, xd, u):
        xd[0] += 1.0
        if self.distorted:
            R_wl, p_wl = u.world.link_pose(self.row)
            xd[1], xd[2] = 1.0, t
            xd[3:6], xd[6:10] = p_wl, quaternion_xyzw(R_wl)

    def sample(self, world: RayCaster, t: float, seq: int, previous=None) -> LidarScan:
        """The scan at t; ``previous`` (t₀, p (3,), quaternion xyzw (4,)): the mount link's pose at the last
        sample (motion distortion; None: every beam cast at t)."""
        p, pat = self.p, self.pattern
        R_wl, p_wl = world.link_pose(self.row)
        R = R_wl @ self.R_ls
        origin = p_wl + R_wl @ self.p_ls
        cast_o, cast_d, bundle = self._moved(previous, t, R_wl, p_wl)
        extra = {} if p.texture_contrast == 1.0 else {"texture_contrast": p.texture_contrast}
        # hits nearer than min_range only block (TOO_CLOSE): refined only as far as telling so
        hits, _, d_w = world.cast_from(R, origin, cast_o, cast_d, self.max_range, SELF_HIT_GUARD,
                                       bundle, self.buffers, p.terrain_hits == "exact", self.min_range, **extra)
        n = len(hits.distance)
        status, measured, intensity = np.empty(n, dtype=np.uint8), np.empty(n), np.empty(n, dtype=np.float32)
        points = np.empty((n, 3), dtype=np.float32)
        _returns(self.order, hits.distance, hits.normal, hits.albedo, d_w, self.min_range, p.reference_range,
                 p.intensity == "reflectivity", pat.origins, pat.directions, status, measured, intensity, points)
        label = np.empty(n, dtype=LABEL_DTYPE)
        label[self.order] = labels_of(hits)                  # the cast's buffers are reused: copied
        if p.attenuation > 0 or p.detection_threshold > 0:
            self._attenuate(status, measured, intensity)
        noisy = p.range_noise > 0 or p.range_noise_slope > 0
        if noisy or p.dropout > 0 or p.packet_loss > 0:
            ret = status == RETURN
            # the sample counter in the second word (.sensors.noise: in the first, Philox would hand
            # sample k + 1 the draws of sample k shifted by four)
            gen = np.random.Generator(np.random.Philox(key=int(p.seed), counter=[0, seq, 0, 0]))
            if noisy:
                measured = measured + (p.range_noise + p.range_noise_slope * measured) * gen.standard_normal(n)
            lost = np.zeros(n, dtype=bool)
            if p.dropout > 0:
                lost |= ret & (gen.random(n) < p.dropout)
            if p.packet_loss > 0:
                lost[self.order] |= (gen.random(p.packets) < p.packet_loss)[self.packet]
            status[lost] = DROPOUT
            measured[lost] = np.nan
            intensity[lost] = 0.0
            _points(pat.origins, pat.directions, measured, points)        # at the noisy ranges
        pose = np.r_[origin, quaternion_xyzw(R)]
        return LidarScan(t, self.frame_id, points, measured.astype(np.float32), intensity, status, self.ring,
                         pat.shape, pose, seq, label, self.time)

    def _moved(self, previous, t: float, R_wl: np.ndarray, p_wl: np.ndarray):
        """The rays to cast and their bundle: each beam moved to the lidar's pose at its firing time in the
        current lidar frame (.motion), or the nominal ones (no distortion, no previous pose, no motion)."""
        if previous is None:
            return self.cast_o, self.cast_d, self.bundle
        t0, p_l0, q_l0 = previous
        if t <= t0 or (np.array_equal(p_l0, p_wl) and np.array_equal(q_l0, quaternion_xyzw(R_wl))):
            return self.cast_o, self.cast_d, self.bundle
        back = self.fire_back * ((1.0 / self.rate) / (t - t0))          # 1 − u per distinct firing time
        R_m, p_m = relative_motion(rotation_matrices(np.asarray(q_l0))[()], np.asarray(p_l0), R_wl, p_wl,
                                   self.R_ls, self.p_ls, back)
        move_rays(self.fire_slot, R_m, p_m, self.cast_o, self.cast_d, self.moved_o, self.moved_d)
        return self.moved_o, self.moved_d, self.moved_bundle

    def _attenuate(self, status, measured, intensity) -> None:
        """The medium (module docstring): intensity times exp(−2αr) at the true range; returns whose raw
        received intensity falls below the detection threshold lost (WEAK)."""
        p = self.p
        ret = np.flatnonzero(status == RETURN)
        r = measured[ret]
        intensity[ret] *= np.exp(-2.0 * p.attenuation * r).astype(np.float32)
        raw = intensity[ret] * ((p.reference_range / r) ** 2 if p.intensity == "reflectivity" else 1.0)
        weak = ret[raw < p.detection_threshold]
        status[weak], measured[weak], intensity[weak] = WEAK, np.nan, 0.0


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
