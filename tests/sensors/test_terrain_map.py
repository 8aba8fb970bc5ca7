"""terrain_map: the elevation of a tilted plane is its analytic height to the search tolerance and its cost the
analytic slope mapping; a block's step is lethal and the flat ground free; cells with no surface in range are
unknown (−1); the exported SDF volume holds Terrain.query's distances and round-trips; bad params are clear."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.sensors.terrain_map import (MAX_CELLS, SDF_VOLUME_FORMAT, TerrainMap, export_sdf_volume,
                                                     load_sdf_volume, trace_down)
from snakesim.components.terrain.analytic import PlaneTerrain
from snakesim.components.terrain.obstacles import Block, ObstacleField
from snakesim.framework import Harness
from snakesim.framework.registry import build_registry
from snakesim.framework.session import load_session

ROBOT = RobotModel.load(design="eels-1.5")


def _map(terrain, center, params=None, rate=None):
    h = Harness(TerrainMap, params or {}, rate=rate, uses={"robot": ROBOT})
    h.inputs.terrain = terrain
    poses = np.zeros((ROBOT.nl, 7))
    poses[:, 6] = 1.0
    poses[:, :3] = center
    h.inputs.link_poses = poses
    return h


def _centres(out, res):
    n = out["elevation"].shape[0]
    c = (np.arange(n) + 0.5) * res
    x, y = np.meshgrid(out["map_origin"][0] + c, out["map_origin"][1] + c)   # [row, col]: row y, col x
    return x, y


def test_tilted_plane_elevation_slope_and_cost_are_analytic():
    tilt, az, tol, res = 0.2, 0.7, 1e-5, 0.1
    plane = PlaneTerrain(tilt=tilt, azimuth=az)
    center = (0.33, -0.21, 0.5)
    h = _map(plane, center, {"resolution": res, "extent": 2.0, "tolerance": tol, "max_slope": 0.5})
    assert h.c.rate == 1.0                                                         # the default rate
    h.update()
    out = h.outputs()
    assert out["elevation"].shape == out["cost"].shape == out["slope"].shape == (20, 20)
    assert out["cost"].dtype == np.int8
    # the corner is snapped to the resolution
    corner = [res * round((0.33 - 1.0) / res), res * round((-0.21 - 1.0) / res), 0.0]
    np.testing.assert_allclose(out["map_origin"], corner, atol=1e-12)
    x, y = _centres(out, res)
    exact = np.tan(tilt) * (x * np.cos(az) + y * np.sin(az))
    err = out["elevation"] - exact
    assert np.isfinite(err).all()
    assert err.min() >= -1e-12 and err.max() <= tol / np.cos(tilt) + 1e-12       # safe steps: never below
    np.testing.assert_allclose(out["slope"], tilt, atol=2 * tol / res)
    assert (out["cost"] == round(100 * tilt / 0.5)).all()                         # 40
    # steeper than max_slope: lethal everywhere
    steep = _map(plane, center, {"resolution": res, "extent": 2.0, "tolerance": tol, "max_slope": 0.15})
    steep.update()
    assert (steep.outputs()["cost"] == 100).all()


def test_step_obstacle_is_lethal_and_flat_ground_free():
    res = 0.1
    block = Block(center=(0.5, 0.0, 0.1), size=(0.4, 0.4, 0.2))        # footprint x 0.3..0.7, y -0.2..0.2
    field = ObstacleField(blocks=[block])
    h = _map(field, (0.02, 0.01, 0.3), {"resolution": res, "extent": 2.0, "max_step": 0.1, "tolerance": 1e-6})
    h.update()
    out = h.outputs()
    x, y = _centres(out, res)
    on = (np.abs(x - 0.5) < 0.2) & (np.abs(y) < 0.2)
    np.testing.assert_allclose(out["elevation"][on], 0.2, atol=1e-6)
    np.testing.assert_allclose(out["elevation"][~on], 0.0, atol=1e-6)
    # step cells: the block's cells and the ground cells touching them (8-neighbourhood)
    near = (np.abs(x - 0.5) < 0.2 + res) & (np.abs(y) < 0.2 + res)
    edge = near & ~((np.abs(x - 0.5) < 0.2 - res) & (np.abs(y) < 0.2 - res))
    assert edge.sum() > 20
    assert (out["cost"][edge] == 100).all()
    assert (out["cost"][~edge] == 0).all()
    # a step below max_step is no obstacle by itself (its slope still costs)
    low = _map(field, (0.02, 0.01, 0.3), {"resolution": res, "extent": 2.0, "max_step": 0.25, "max_slope": 1.5})
    low.update()
    c = low.outputs()["cost"]
    assert (c[edge] < 100).all() and (c[~edge] == 0).all()
    # slope by central differences: 0.2 m over 2 cells, atan(1) = 0.785 rad -> 52; cells touching the block
    # only diagonally see no gradient (the step term is what catches them)
    assert np.isin(c[edge], [0, 52, 64]).all() and (c[edge] == 52).sum() > 20


def test_cells_without_surface_in_range_are_unknown():
    res, tilt = 0.1, 0.6
    plane = PlaneTerrain(tilt=tilt)                      # z = tan(0.6)·x: 0.68 m per m
    h = _map(plane, (0.0, 0.0, 0.0), {"resolution": res, "extent": 4.0, "height": 0.5, "depth": 0.5})
    h.update()
    out = h.outputs()
    x, _ = _centres(out, res)
    z = np.tan(tilt) * x
    above, below = z > 0.5 + 1e-3, z < -0.5 - 1e-3       # start inside the solid / nothing above z_bottom
    inside = np.abs(z) < 0.5 - 1e-3
    assert above.any() and below.any() and inside.any()
    assert np.isnan(out["elevation"][above | below]).all() and np.isnan(out["slope"][above | below]).all()
    assert (out["cost"][above | below] == -1).all()
    assert np.isfinite(out["elevation"][inside]).all() and (out["cost"][inside] >= 0).all()
    # a terrain far below: all unknown
    deep = _map(PlaneTerrain(origin=(0, 0, -10)), (0.0, 0.0, 0.0), {"resolution": 0.5, "extent": 2.0})
    deep.update()
    assert (deep.outputs()["cost"] == -1).all()


def test_each_sample_follows_the_link_and_is_stamped():
    plane = PlaneTerrain()
    h = _map(plane, (0.0, 0.0, 0.2), {"resolution": 0.5, "extent": 2.0, "link": "module_02"}, rate=2.0)
    out = h.outputs(0.5)
    np.testing.assert_allclose(out["map_origin"], [-1.0, -1.0, 0.0])
    assert out["sample_time"] == 0.5
    h.inputs.link_poses = np.tile([3.0, 1.0, 0.2, 0, 0, 0, 1.0], (ROBOT.nl, 1))
    out = h.outputs(1.0)
    np.testing.assert_allclose(out["map_origin"], [2.0, 0.0, 0.0])
    assert out["sample_time"] == 1.0
    assert h.update(1.0)[0] == 1.0                                                 # the sample counter


def test_sdf_volume_is_the_terrain_query_and_round_trips(tmp_path):
    field = ObstacleField(blocks=[Block(center=(0.5, 0.0, 0.1), size=(0.4, 0.4, 0.2), yaw=0.3)])
    lo, hi, res = (-1.0, -0.5, -0.2), (1.0, 0.5, 0.6), 0.05
    path = export_sdf_volume(field, (lo, hi), res, tmp_path / "sdf.npz")
    v = load_sdf_volume(path)
    assert v["distance"].shape == (41, 21, 17) and v["distance"].dtype == np.float64
    np.testing.assert_array_equal(v["origin"], lo)
    assert v["resolution"] == res and v["format"] == SDF_VOLUME_FORMAT and v["terrain"] == field.name
    rng = np.random.default_rng(0)
    idx = np.column_stack([rng.integers(0, s, 200) for s in v["distance"].shape])
    pts = v["origin"] + res * idx
    np.testing.assert_array_equal(v["distance"][tuple(idx.T)], field.query(pts).distance)
    # a second write reads back identical
    v2 = load_sdf_volume(export_sdf_volume(field, (lo, hi), res, tmp_path / "again.npz"))
    np.testing.assert_array_equal(v2["distance"], v["distance"])


def test_sdf_volume_bad_arguments(tmp_path):
    plane = PlaneTerrain()
    with pytest.raises(ValueError, match="resolution"):
        export_sdf_volume(plane, ((0, 0, 0), (1, 1, 1)), 0.0, tmp_path / "a.npz")
    with pytest.raises(ValueError, match="resolution"):
        export_sdf_volume(plane, ((0, 0, 0), (100, 100, 100)), 0.01, tmp_path / "a.npz")
    with pytest.raises(ValueError, match="bounds"):
        export_sdf_volume(plane, ((0, 0, 0), (1, 1, np.inf)), 0.1, tmp_path / "a.npz")


@pytest.mark.parametrize("params, key", [
    ({"resolution": 0.0}, "resolution"),
    ({"resolution": -0.1}, "resolution"),
    ({"extent": 1000.0, "resolution": 0.01}, "extent"),
    ({"extent": 0.01, "resolution": 0.1}, "extent"),
    ({"max_slope": 2.0}, "max_slope"),
    ({"max_step": 0.0}, "max_step"),
])
def test_bad_params_name_the_key(params, key):
    with pytest.raises(Exception, match=key):
        TerrainMap("map", params, None, uses={"robot": ROBOT})
    assert MAX_CELLS == 1_000_000


def test_bad_link_lists_the_links():
    with pytest.raises(Exception, match="module_02"):
        _map(PlaneTerrain(), (0, 0, 0), {"link": "nope"})


def test_trace_stops_at_max_iterations():
    # a ray grazing a vertical wall creeps: unconverged cells are unknown, never wrong
    field = ObstacleField(blocks=[Block(center=(0.0, 0.0, 1.0), size=(1.0, 1.0, 2.0))])
    z = trace_down(field, np.array([[0.5 + 1e-4, 0.0], [3.0, 0.0]]), 2.5, -1.0, 1e-6, 50)
    assert np.isnan(z[0]) and abs(z[1]) < 1e-6


def test_in_a_scene_the_map_is_sampled_at_its_rate_and_recorded(tmp_path):
    """Wired as an assembly wires it (registered type, robot handed over, NaN cells recorded): the map
    follows the root link, flat ice is free, the course's obstacles are lethal."""
    (tmp_path / "s.yaml").write_text(textwrap.dedent("""
        sim: {duration: 1.0, dt: 0.01, record_rate: 10}
        components:
          terrain: {type: terrain, params: {name: obstacle-course}}
          robot: {type: multibody, params: {design: eels-1.0, modules: 2, gravity: [0, 0, 0],
                                            base_position: [0.0, 0.0, 0.3]}}
          map: {type: terrain_map, rate: 2, params: {resolution: 0.1, extent: 6.0}}
        connections:
          - terrain.terrain -> map.terrain
          - robot.link_poses -> map.link_poses
        record: [map.map_origin, map.cost, map.elevation, map.sample_time]
    """))
    session = load_session(tmp_path / "s.yaml", registry=build_registry(load_entry_points=False))
    assert session.plan.components["map"].robot is session.plan.components["robot"].robot
    res = session.run()
    t = res["t"]
    cost = res["map.cost"].reshape(t.size, 60, 60)
    elev = res["map.elevation"].reshape(t.size, 60, 60)
    # sampled at the map's ticks (0, 0.5, ...) and held in between (the recorder reads at 10 Hz)
    np.testing.assert_allclose(res["map.sample_time"], np.floor(t * 2.0 + 1e-9) / 2.0, atol=1e-12)
    np.testing.assert_allclose(res["map.map_origin"], [[-3.0, -3.0, 0.0]] * t.size, atol=1e-12)
    c = cost[-1]
    assert (c == 0).mean() > 0.5 and (c == 100).any()
    assert np.nanmax(elev[-1]) > 0.1 and np.nanmin(elev[-1]) > -1e-3
