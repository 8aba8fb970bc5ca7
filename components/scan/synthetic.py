"""Synthetic field scans: a lidar lowered down a rope into a terrain, cast with the sensors' own ray caster.

A field team surveys a moulin by lowering a scanner on a rope from the mouth and stopping at a few depths; at
each stop the head turns a full circle. Here: ``poses`` stops at heights z evenly from ``top`` to ``bottom`` (m,
world) on the vertical rope through (x, y) = ``rope``; at stop k the head is yawed by k·(golden angle) (a real
head never stops at the same azimuth twice, so the stops' columns do not line up) and fires its pattern
(:class:`ScanPattern`: a spinning grid, vertical axis, ``channels`` elevations over ``vertical_fov``, ``columns``
azimuths a turn; or several such grids tilted about the head's x axis). Each beam is cast against the terrain
(.perception.ray_caster: Embree on the terrain's sensor mesh, hits on a curved analytic surface refined onto it
in float64 by Newton's method on its signed distance), so the rough wall hides itself from the rope where it
does (occlusion holes come from the geometry, nothing is added for them). A sensor-mesh hit off the terrain's
true surface by more than ``OFF_SURFACE`` (the flat surface's polygon cut around a moulin's mouth overhangs the
opening) is no return: the beam goes out through the opening. A return at true range r from the
stop's position o along unit d is then degraded as the lidar's knobs do (.perception.lidar), seeded:

    range noise   r_m = r + σ(r)·ε, ε ~ N(0, 1), σ(r) = range_noise + range_noise_slope·r (m): the point is
                  o + r_m·d, so it stays on the beam from its scanner
    grazing       a return whose incidence angle (between the beam and the wall's normal) exceeds ``grazing``
                  (deg) is lost: too little of the footprint's power comes back (the far ends of a thin slot)
    dropout       each remaining return lost with probability ``dropout`` (random)
    masks         a return within a mask sphere (centre (3,) m, radius m) is lost: a wet, dark patch of the
                  wall that returns nothing
    thinning      with ``thin`` > 0 one return per cubic voxel of that edge (m) is kept, chosen at random
                  (seeded): the registered, merged cloud a field team hands over, its density evened out;
                  voxels of the noise-free hits, so that the thinning leaves the noise's statistics as they are

The draws (noise, dropout; then the thinning's keys) come from a Philox generator keyed by ``seed`` with the
stop's index in the counter's second word (.sensors.noise): the same arguments give the same scan, bit for bit.

Each point carries its scanner position (the stop it was measured from), the stop's index, the time it was
measured (stop k starts at k·``dwell`` s; the head turns once in ``period`` s, a beam firing at its column's
fraction of the turn, .perception.beam_patterns) and its diffuse reflectivity ρ·cos θ (.perception.reflectance,
from the noise-free hit). Units m, s; frame: the terrain's world frame, z up.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from snakesim.components.perception.beam_patterns import BeamGrid, BeamPattern
from snakesim.components.perception.reflectance import lidar_intensity

#: rad: the head's yaw advances by this from one stop to the next (the golden angle: no two stops alike)
GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))
#: m: a sensor-mesh hit farther than this from the terrain's zero level set is not on its surface (dropped)
OFF_SURFACE = 1e-4
#: the tilts (deg, about the head's x axis) of the ``tilted`` pattern: three grids, level and ±35 deg
TILTED = (-35.0, 0.0, 35.0)


@dataclasses.dataclass(frozen=True)
class ScanPattern:
    """The head's beams: a spinning grid (.perception.beam_patterns.BeamGrid, axis z, a full turn) repeated at
    each tilt (deg, about the head's x axis). ``vertical_fov`` (lo, hi) deg."""

    channels: int = 96
    columns: int = 1024
    vertical_fov: tuple[float, float] = (-70.0, 70.0)
    tilts: tuple[float, ...] = (0.0,)

    def beams(self) -> BeamPattern:
        grid = BeamGrid(channels=self.channels, horizontal_samples=self.columns,
                        vertical_fov=tuple(self.vertical_fov)).beams()
        d, fire, ring = [], [], []
        for i, tilt in enumerate(self.tilts):
            c, s = math.cos(math.radians(tilt)), math.sin(math.radians(tilt))
            R = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
            d.append(grid.directions @ R.T)
            fire.append(grid.fire)
            ring.append(grid.ring + i * self.channels)
        d = np.concatenate(d)
        return BeamPattern(np.zeros_like(d), d, np.concatenate(ring), None, np.concatenate(fire))


@dataclasses.dataclass(frozen=True)
class ScanSettings:
    """Everything a synthetic scan depends on (module docstring); units m, deg, s."""

    top: float = -0.5
    bottom: float = -7.5
    poses: int = 15
    rope: tuple[float, float] = (0.0, 0.0)
    pattern: ScanPattern = ScanPattern()
    min_range: float = 0.1
    max_range: float = 10.0
    range_noise: float = 0.003
    range_noise_slope: float = 0.0
    dropout: float = 0.01
    grazing: float = 90.0
    masks: tuple[tuple[float, float, float, float], ...] = ()
    thin: float = 0.0
    seed: int = 0
    period: float = 0.1
    dwell: float = 5.0

    def __post_init__(self):
        bad = []
        if not self.poses >= 1:
            bad.append(f"poses = {self.poses}: at least 1")
        if not self.top >= self.bottom:
            bad.append(f"top = {self.top:g} m is below bottom = {self.bottom:g} m: top must be >= bottom")
        if not (self.range_noise >= 0 and math.isfinite(self.range_noise)):
            bad.append(f"range_noise = {self.range_noise:g} m: must be >= 0")
        if not (self.range_noise_slope >= 0 and math.isfinite(self.range_noise_slope)):
            bad.append(f"range_noise_slope = {self.range_noise_slope:g}: must be >= 0")
        if not 0.0 <= self.dropout < 1.0:
            bad.append(f"dropout = {self.dropout:g}: a probability in [0, 1)")
        if not 0.0 < self.grazing <= 90.0:
            bad.append(f"grazing = {self.grazing:g} deg: in (0, 90] (90: no return lost for its incidence)")
        if not 0.0 <= self.min_range < self.max_range:
            bad.append(f"min_range = {self.min_range:g} m, max_range = {self.max_range:g} m: need "
                       "0 <= min_range < max_range")
        if not (self.thin >= 0 and math.isfinite(self.thin)):
            bad.append(f"thin = {self.thin:g} m: a voxel edge >= 0 (0: keep every return)")
        if self.seed < 0:
            bad.append(f"seed = {self.seed}: must be >= 0")
        for m in self.masks:
            if len(m) != 4 or not m[3] > 0:
                bad.append(f"mask {list(m)}: X, Y, Z, RADIUS with RADIUS > 0 (m)")
        p = self.pattern
        if p.channels < 1 or p.columns < 1:
            bad.append(f"pattern: channels = {p.channels}, columns = {p.columns}: at least 1 each")
        lo, hi = p.vertical_fov
        if not -90.0 <= lo <= hi <= 90.0:
            bad.append(f"pattern: vertical_fov = [{lo:g}, {hi:g}] deg: need -90 <= lo <= hi <= 90")
        if bad:
            raise ValueError("; ".join(bad))

    def stops(self) -> np.ndarray:
        """(poses, 3) m the scanner's positions, from ``top`` down."""
        z = np.linspace(self.top, self.bottom, self.poses) if self.poses > 1 else np.array([self.top])
        return np.column_stack([np.full(self.poses, self.rope[0]), np.full(self.poses, self.rope[1]), z])


@dataclasses.dataclass(frozen=True)
class SyntheticScan:
    """The kept returns: points (n, 3) m, scanner (n, 3) m (the stop each was measured from), pose (n,) int the
    stop's index, time (n,) s, intensity (n,) ρ·cos θ, range (n,) m measured, true_range (n,) m (before the
    noise: the test's and the provenance's ground truth), direction (n, 3) the unit beam; stops (poses, 3) m and
    stop_times (poses,) s; counts (dict): beams cast, returns, and those lost to grazing, dropout, masks and
    thinning, and the mesh hits off the surface (``OFF_SURFACE``: not returns)."""

    points: np.ndarray
    scanner: np.ndarray
    pose: np.ndarray
    time: np.ndarray
    intensity: np.ndarray
    range: np.ndarray
    true_range: np.ndarray
    direction: np.ndarray
    stops: np.ndarray
    stop_times: np.ndarray
    counts: dict

    def __len__(self) -> int:
        return len(self.points)


def check_rope(terrain, settings: ScanSettings) -> None:
    """A ValueError naming ``rope``, ``top`` or ``bottom`` if a stop is inside the terrain (signed distance <= 0:
    the scanner in the ice)."""
    stops = settings.stops()
    d = terrain.query(stops).distance
    inside = np.flatnonzero(~(d > 0))
    if inside.size:
        k = inside[0]
        raise ValueError(f"rope = ({settings.rope[0]:g}, {settings.rope[1]:g}) m: the scanner at stop {k} "
                         f"(z = {stops[k, 2]:g} m) is inside the terrain (signed distance {d[k]:.4g} m); "
                         f"{inside.size} of {len(stops)} stops are: put the rope in the void, between top and "
                         "bottom where the terrain is open")


def scan_terrain(terrain, settings: ScanSettings, cell: float = 0.05) -> SyntheticScan:
    """Cast ``settings``' scan against ``terrain`` (a loaded Terrain); ``cell`` m the sensor mesh's
    tessellation (hits on curved analytic kinds are refined onto the exact surface whatever it is)."""
    from snakesim.components.perception.ray_caster import EmbreeWorld, StaticTerrainScene
    from snakesim.components.perception.surfaces import terrain_surfaces

    s = settings
    check_rope(terrain, s)
    stops = s.stops()
    centre = stops.mean(axis=0)
    extent = s.max_range + 0.5 * (s.top - s.bottom)         # a half-size: tube ±extent, moulin 2·extent deep
    world = EmbreeWorld(0.0, StaticTerrainScene(terrain_surfaces(terrain, centre, extent, cell)), None, None)
    pattern = s.pattern.beams()
    head, fire = pattern.directions, pattern.fire
    stop_times = np.arange(s.poses) * s.dwell
    parts, counts = [], {"beams": 0, "returns": 0, "grazing": 0, "dropout": 0, "masked": 0, "thinned": 0,
                     "off_surface": 0}
    cos_grazing = math.cos(math.radians(s.grazing))
    for k, o in enumerate(stops):
        yaw = k * GOLDEN_ANGLE
        c, sn = math.cos(yaw), math.sin(yaw)
        d = np.ascontiguousarray(head @ np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]]).T)
        n = len(d)
        hits = world.cast(np.broadcast_to(o, (n, 3)), d, s.max_range, s.min_range)
        r = hits.distance.copy()                        # the cast's arrays: copied before the next cast
        hit = np.flatnonzero(np.isfinite(r))
        # a hit on a sensor-mesh face that is not the terrain's surface (the flat surface's polygon cut around a
        # moulin's mouth overhangs the opening by up to a cell): the beam goes on through the opening
        off = np.abs(terrain.query(o + r[hit, None] * d[hit]).distance) > OFF_SURFACE
        counts["off_surface"] += int(np.count_nonzero(off))
        hit = hit[~off]
        cos = np.abs(np.einsum("ij,ij->i", hits.normal[hit], d[hit]))
        albedo = hits.albedo[hit].copy()
        counts["beams"] += n
        counts["returns"] += hit.size
        # draws for every beam of the stop, in a fixed order (noise, dropout), whatever is lost
        gen = np.random.Generator(np.random.Philox(key=int(s.seed), counter=[0, k, 0, 0]))
        eps = gen.standard_normal(n)[hit]
        lost_random = (gen.random(n) < s.dropout)[hit]
        r_true = r[hit]
        r_meas = r_true + (s.range_noise + s.range_noise_slope * r_true) * eps
        points = o + r_meas[:, None] * d[hit]
        graze = cos < cos_grazing if s.grazing < 90.0 else np.zeros(hit.size, dtype=bool)
        masked = _in_masks(o + r_true[:, None] * d[hit], s.masks)
        keep = ~graze & ~masked & ~lost_random
        counts["grazing"] += int(np.count_nonzero(graze))
        counts["masked"] += int(np.count_nonzero(masked & ~graze))
        counts["dropout"] += int(np.count_nonzero(lost_random & ~graze & ~masked))
        kept = hit[keep]
        parts.append((points[keep], np.full(kept.size, k, dtype=np.int32),
                      stop_times[k] + fire[kept] * s.period, lidar_intensity(albedo[keep], cos[keep], r_true[keep],
                                                                            1.0, True),
                      r_meas[keep], r_true[keep], d[kept]))
    points, pose, time, intensity, measured, true_range, direction = (np.concatenate(a) for a in zip(*parts))
    if s.thin > 0:
        gen = np.random.Generator(np.random.Philox(key=int(s.seed), counter=[0, s.poses, 0, 0]))
        # voxels of where the beams met the wall, not of the noisy points: a point the noise carries behind the
        # wall lands in an emptier voxel and would be kept more often (keyed on the noisy points the shipped
        # scan's range noise came out 3.32 mm instead of the 3.00 mm asked)
        chosen = thin_to_voxels(points - (measured - true_range)[:, None] * direction, s.thin, gen)
        counts["thinned"] = len(points) - chosen.size
        points, pose, time, intensity, measured, true_range, direction = (
            a[chosen] for a in (points, pose, time, intensity, measured, true_range, direction))
    counts["kept"] = len(points)
    return SyntheticScan(points, stops[pose], pose, time, intensity.astype(np.float32), measured, true_range,
                         direction, stops, stop_times, counts)


def _in_masks(points: np.ndarray, masks) -> np.ndarray:
    """(n,) whether each true hit lies within a mask sphere (X, Y, Z, R)."""
    inside = np.zeros(len(points), dtype=bool)
    for x, y, z, radius in masks:
        inside |= np.einsum("ij,ij->i", points - (x, y, z), points - (x, y, z)) <= radius * radius
    return inside


def thin_to_voxels(points: np.ndarray, edge: float, gen: np.random.Generator) -> np.ndarray:
    """Indices (sorted) of one point per cubic voxel of ``edge`` m, the one with the smallest random key in its
    voxel (not the first measured: no stop is favoured)."""
    key = gen.random(len(points))
    cell = np.floor(points / edge).astype(np.int64)
    order = np.lexsort((key, cell[:, 2], cell[:, 1], cell[:, 0]))
    c = cell[order]
    first = np.ones(len(order), dtype=bool)
    first[1:] = np.any(c[1:] != c[:-1], axis=1)
    return np.sort(order[first])
