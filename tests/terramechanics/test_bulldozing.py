"""Bulldozing (terrain/bulldozing.py): the soil pressed out of a rut heaped on the patch's rim and eroded to the
angle of repose. Checked against conservation (soil moves between nodes and never out of them: Σ (lift − s_p) Δ²
= −(1 − flow_factor) × the pressed-out volume, to rounding), the repose rule (after enough erosion passes no
pair of neighbours out of contact in the heap differs by more than Δ tan(angle)), the contact nodes left as the
body pressed them, the scene's volume over a run, and the bad-input errors.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.components.terrain.bulldozing import BulldozingSpec, SoilFlowLog
from snakesim.components.terrain.deformable import DeformableTerrain
from snakesim.components.terramechanics.body_kernels import body_soil
from snakesim.components.terramechanics.kernels import SCRATCH_COLUMNS, scratch_rows

from test_rigid_wheel import SAND

R, L, CELL = 0.03, 0.12, 0.002


def press(spec, pen=0.01, steps=1):
    """A cylinder (axis +x) pressed into sand to ``pen`` in ``steps`` committed steps, with bulldozing ``spec``:
    (terrain, the last step's contact nodes' (i, j), the volume the commits pressed out (m³, from their log))."""
    t = DeformableTerrain(0.0, (-0.25, -0.25), (0.5, 0.5), CELL, SAND, max_tiles=128, bulldozing=spec)
    st = t.state
    piece_R = np.array([[[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]])
    rows = scratch_rows(np.array([R]), np.array([L]), CELL)
    scratch = np.zeros((rows, SCRATCH_COLUMNS))
    flow = SoilFlowLog(t, rows)
    w, per_link, totals = np.zeros((1, 6)), np.zeros((1, 3)), np.zeros(2)
    blocks = np.zeros((1, 6, 6)), np.zeros((1, 6, 6)), np.zeros(1, dtype=np.bool_)
    pressed = 0.0
    for step in range(1, steps + 1):
        poses = np.array([[0.0003, -0.0004, R - pen * step / steps, 0.0, 0.0, 0.0, 1.0]])
        body_soil(t.grid, t.base_z, t.soil, st.tile_of, st.plastic, st.yield_p, st.lift, st.used, np.array([0]),
                  np.array([[R, L, 1.0, 1.0]]), piece_R, np.zeros((1, 3)), poses, np.zeros((1, 6)), 1e-3,
                  np.zeros(2), True, flow.entries, flow.count, scratch, w, per_link, totals, False, *blocks)
        contact = scratch[:int(totals[1]), :2].astype(np.int64)
        pressed += flow.entries[:flow.count[0], 2].sum()
        assert flow.apply(t) > 0
    return t, contact, pressed


@pytest.mark.parametrize("flow_factor", [1.0, 0.5, 0.0])
def test_the_pressed_out_volume_is_heaped_on_the_rim_in_proportion(flow_factor):
    """The soil's volume changes by what was compacted only: Σ (lift − s_p) Δ² = −(1 − flow_factor) V, V the
    volume the commits pressed out (their log), however erosion moved the heap about."""
    t, _, pressed = press(BulldozingSpec(erosion_angle=30.0, flow_factor=flow_factor, erosion_iterations=8),
                          steps=3)
    k = t.tiles_used()
    net = (t.state.lift[:k] - t.state.plastic[:k]).sum() * t.cell ** 2
    assert pressed > 1e-6
    # the sums run over ~10⁴ nodes: rounding of order 1e-16 × their count, relative
    assert net == pytest.approx(-(1.0 - flow_factor) * pressed, abs=1e-12 * pressed)


def test_berms_stand_beside_the_rut_at_the_angle_of_repose():
    angle = 30.0
    t, contact, _ = press(BulldozingSpec(erosion_angle=angle, flow_factor=1.0, erosion_iterations=400))
    st = t.state
    relief = np.zeros((int(t.grid[4]), int(t.grid[5])))
    # the relief (lift − s_p) at every node of the used tiles
    from snakesim.components.terrain.deformable_files import node_coordinates

    x, y = node_coordinates(t)
    k = t.tiles_used()
    ii = np.rint((x - t.grid[0]) / CELL).astype(int)
    jj = np.rint((y - t.grid[1]) / CELL).astype(int)
    relief[ii, jj] = st.lift[:k] - st.plastic[:k]
    in_contact = np.zeros_like(relief, dtype=bool)
    in_contact[contact[:, 0], contact[:, 1]] = True
    assert relief.max() > 1e-4                                  # a berm
    # beside the rut: the highest node out of contact touches the contact's edge within a few cells
    top = np.unravel_index(np.argmax(np.where(in_contact, -np.inf, relief)), relief.shape)
    d = np.min(np.hypot(contact[:, 0] - top[0], contact[:, 1] - top[1]))
    assert d <= 3.0
    # the contact nodes keep what the body pressed: no soil slid under it
    assert np.all(st.lift[:k][in_contact[ii, jj]] == 0.0)
    # out of contact, neighbours differ by at most Δ tan(angle) once erosion has settled
    limit = CELL * math.tan(math.radians(angle))
    free = ~in_contact
    for a, b, fa, fb in ((relief[1:], relief[:-1], free[1:], free[:-1]), (relief[:, 1:], relief[:, :-1],
                                                                         free[:, 1:], free[:, :-1])):
        both = fa & fb
        assert np.abs(a - b)[both].max() <= limit * (1 + 1e-9)


def test_a_soil_scene_with_bulldozing_keeps_its_volume(tmp_path):
    """snow-screw-traverse on the snow field with bulldozing (flow factor 1): after settling and driving, the
    soil pressed out equals the soil heaped, berms stand above the base, and the terrain every consumer queries
    has them."""
    from pathlib import Path

    from snakesim.components.terrain.deformable_files import rut_summary
    from snakesim.framework.session import load_session

    text = (Path(__file__).parents[2] / "terrains" / "snow-field.yaml").read_text()
    path = tmp_path / "snow-bulldozing.yaml"
    path.write_text(text + "bulldozing: {erosion_angle: 35.0, flow_factor: 1.0, erosion_iterations: 5}\n")
    s = load_session("snow-screw-traverse", overrides=["settle=0.5", f"terrain={path}"],
                     sim_overrides={"duration": 1.0})
    result = s.run(out_dir=tmp_path / "run")
    assert result.summary["outcome"] == "success"
    terrain = s.plan.caches["contact"].terrain
    rs = rut_summary(terrain)
    assert rs["rut_volume_m3"] > 1e-3
    assert abs(rs["net_volume_m3"]) <= 1e-12 * rs["rut_volume_m3"] * rs["deformed_nodes"]
    assert rs["max_berm_height_m"] > 0.005
    assert result.summary["reports"]["contact"]["rut"]["heaped_volume_m3"] == pytest.approx(rs["heaped_volume_m3"])
    # the query sees the berm: its highest node stands above the base by the berm's height
    from snakesim.components.terrain.deformable_files import node_coordinates

    x, y = node_coordinates(terrain)
    k = terrain.tiles_used()
    relief = terrain.state.lift[:k] - terrain.state.plastic[:k]
    top = np.unravel_index(np.argmax(relief), relief.shape)
    h = terrain.surface_height(x[top], y[top]) - terrain.surface_height(x[top], y[top], virgin=True)
    assert float(h) == pytest.approx(rs["max_berm_height_m"], rel=1e-9)


@pytest.mark.parametrize("value,key", [("{erosion_angle: 95.0}", "erosion_angle"),
                                       ("{flow_factor: 1.5}", "flow_factor"),
                                       ("{erosion_iterations: -1}", "erosion_iterations"),
                                       ("{erosion_angel: 30.0}", "erosion_angel")])
def test_bad_bulldozing_names_the_file_and_key(tmp_path, value, key):
    from pathlib import Path

    from snakesim.components.terrain.spec import load_terrain
    from snakesim.framework.errors import SnakesimError

    text = (Path(__file__).parents[2] / "terrains" / "snow-field.yaml").read_text()
    path = tmp_path / "bad-bulldozing.yaml"
    path.write_text(text + f"bulldozing: {value}\n")
    with pytest.raises(SnakesimError) as e:
        load_terrain(str(path))
    msg = str(e.value)
    assert "bad-bulldozing.yaml" in msg and key in msg


def test_a_lidar_and_the_viewer_see_the_berms():
    """Beams straight down from 1 m over the rut and its berms return 1 m + the depth below the base (less
    on a berm), and the display mesh has the berms' heights: bulldozed soil is what every consumer sees."""
    from snakesim.components.perception.ray_caster import EmbreeWorld, StaticTerrainScene
    from snakesim.components.perception.surfaces import terrain_surfaces
    from snakesim.components.terrain.derived import TerrainDerived

    t, _, _ = press(BulldozingSpec(erosion_angle=30.0, flow_factor=1.0, erosion_iterations=20))
    xs = t.grid[0] + CELL * np.arange(100, 151, 2)               # on nodes, across and along the rut
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    x, y = X.ravel(), Y.ravel()
    depth = t.rut_depth(x, y)
    assert depth.min() < -1e-4 and depth.max() > 1e-3           # berms and the rut under the beams
    scene = TerrainDerived(lambda terrain: StaticTerrainScene(terrain_surfaces(terrain, (0.0, 0.0, 0.0), 0.3,
                                                                               CELL)))
    o = np.column_stack([x, y, np.ones_like(x)])
    hits = EmbreeWorld(0.0, scene.get(t), None, None).cast(o, np.tile([0.0, 0.0, -1.0], (x.size, 1)), 5.0)
    np.testing.assert_allclose(hits.distance, 1.0 + depth, atol=1e-6)
    mesh = t.display_mesh((0.0, 0.0, 0.0), 0.1, CELL, None)
    v = np.asarray(mesh.vertices, dtype=np.float64)
    on = np.abs(v[:, :2] / CELL - np.round(v[:, :2] / CELL)).max(axis=1) < 1e-6
    np.testing.assert_allclose(v[on, 2], -t.rut_depth(v[on, 0], v[on, 1]), atol=1e-6)
    assert v[on, 2].max() > 1e-4                                  # a berm among the vertices
