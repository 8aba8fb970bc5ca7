"""A spinning lidar's motion distortion against closed forms: between parallel walls y = ±g/2, a lidar
that moved (or turned) between two samples casts each beam from where it was when the beam fired,
t − (1 − s)·T for a column at firing fraction s (.beam_patterns), so each range is the wall's
distance from that point along that direction; its points are in the lidar frame of that instant
and its time field says when. Off, or on a rosette by default, every beam is cast at the stamp."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenes import F32, USES, all_links_at, terrain, world_at
from snakesim.components.perception import Lidar
from snakesim.framework import Harness

GAP, RATE = 0.8, 10.0
T = 1.0 / RATE
COLUMNS = 72
RING = {"kind": "grid", "channels": 1, "horizontal_samples": COLUMNS, "vertical_fov": (0.0, 0.0)}
WALLS = terrain({"kind": "parallel_walls", "gap": GAP})
#: a 360° grid's column j: azimuth π − (j + ½)·2π/h, fired at fraction (j + ½)/h of the period
AZIMUTH = math.pi - (np.arange(COLUMNS) + 0.5) * 2 * math.pi / COLUMNS
FIRE = (np.arange(COLUMNS) + 0.5) / COLUMNS


def yaw_quat(yaw: float):
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def two_samples(pose0, pose1, **params):
    """The scan at t = T after a first sample at t = 0 with every link at pose0, then pose1."""
    h = Harness(Lidar, {"link": "lidar", "beams": RING, "max_range": 50.0, **params}, rate=RATE, uses=USES)
    h.inputs.world = world_at(WALLS, all_links_at(*pose0))
    h.outputs(0.0)
    h.update(0.0)
    h.inputs.world = world_at(WALLS, all_links_at(*pose1))
    return h.outputs(T)["scan"]


def wall_range(y, heading):
    """Range from height y along world heading (rad) to the walls y = ±g/2."""
    s = np.sin(heading)
    return np.where(s > 0, (GAP / 2 - y) / np.where(s > 0, s, 1.0), (GAP / 2 + y) / np.where(s < 0, -s, 1.0))


def test_moving_lidar_casts_each_beam_from_where_it_was():
    y0, y1 = -0.05, 0.15                       # 2 m/s across the walls over one period
    scan = two_samples(((0.0, y0, 0.0),), ((0.0, y1, 0.0),))
    y_fire = y1 - (1.0 - FIRE) * (y1 - y0)     # linear between the samples
    expected = wall_range(y_fire, AZIMUTH)
    np.testing.assert_allclose(scan.range, expected, rtol=16 * F32)
    np.testing.assert_allclose(scan.time, -(1.0 - FIRE) * T, rtol=1e-6)
    # the points are in the lidar frame of each beam's instant: along the nominal beam
    np.testing.assert_allclose(scan.points[:, 1], expected * np.sin(AZIMUTH), atol=1e-5)
    # every beam's hit moved by v·Δt against the scan cast at the stamp
    still = two_samples(((0.0, y0, 0.0),), ((0.0, y1, 0.0),), motion_distortion=False)
    np.testing.assert_allclose(still.range, wall_range(np.full(COLUMNS, y1), AZIMUTH), rtol=16 * F32)
    assert np.all(still.time == 0)
    shift = scan.points[:, 1] - still.points[:, 1]          # the walls seen from where the lidar was
    np.testing.assert_allclose(shift, (1.0 - FIRE) * (y1 - y0), atol=1e-5)
    assert np.abs(shift).max() > 0.1                                       # the test can tell


def test_turning_lidar_off_its_link_axis_sweeps_an_arc():
    """The link turns about its origin at ω = Δψ/T; the lidar 0.1 m out along its x follows the arc (the
    link's pose is interpolated along the geodesic, not the lidar's along the chord)."""
    psi0, psi1, arm = 0.0, 0.6, 0.1
    scan = two_samples(((0.0, 0.0, 0.0), yaw_quat(psi0)), ((0.0, 0.0, 0.0), yaw_quat(psi1)), xyz=(arm, 0.0, 0.0))
    psi = psi1 - (1.0 - FIRE) * (psi1 - psi0)
    expected = wall_range(arm * np.sin(psi), AZIMUTH + psi)
    np.testing.assert_allclose(scan.range, expected, rtol=16 * F32)
    still = wall_range(np.full(COLUMNS, arm * math.sin(psi1)), AZIMUTH + psi1)
    assert np.abs(scan.range - still).max() > 0.1


def test_a_still_lidar_and_the_first_sample_are_cast_at_one_instant():
    first = Harness(Lidar, {"link": "lidar", "beams": RING, "max_range": 50.0}, rate=RATE, uses=USES)
    first.inputs.world = world_at(WALLS, all_links_at((0.0, 0.1, 0.0)))
    scan = first.outputs(0.0)["scan"]                       # no previous pose
    np.testing.assert_allclose(scan.range, wall_range(np.full(COLUMNS, 0.1), AZIMUTH), rtol=16 * F32)
    still = two_samples(((0.0, 0.1, 0.0),), ((0.0, 0.1, 0.0),))
    np.testing.assert_array_equal(still.range, scan.range)


def test_defaults_and_a_file_without_firing_times(tmp_path):
    world = world_at(WALLS, all_links_at((0.0, 0.0, 0.0)))
    h = Harness(Lidar, {"link": "lidar", "preset": "solid-state-rosette"}, rate=RATE, uses=USES)
    h.inputs.world = world
    assert not h.c.distorted and np.all(h.outputs()["scan"].time == 0)
    assert Harness(Lidar, {"link": "lidar", "preset": "spinning-32"}, rate=RATE, uses=USES).c.distorted
    on = Harness(Lidar, {"link": "lidar", "preset": "solid-state-rosette", "motion_distortion": True}, rate=RATE,
                 uses=USES)
    on.inputs.world = world
    t = on.outputs()["scan"].time
    assert t.min() == pytest.approx(-T, rel=1e-6) and t.max() < 0
    path = tmp_path / "beams.csv"
    path.write_text("1,0,0\n0,1,0\n")
    with pytest.raises(ValueError, match="motion_distortion.*firing times"):
        Harness(Lidar, {"link": "lidar", "beams": {"kind": "file", "path": str(path)}, "motion_distortion": True},
                rate=RATE, uses=USES)
