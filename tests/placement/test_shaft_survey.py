"""survey_shaft (components/placement/shaft_survey.py) against shafts whose geometry is known independently:
parallel walls (exact planes), the analytic moulin-slot (its wall offsets from SlotMoulin.half_width/centre,
not from rays), and a slot meshed with trimesh and imported as a mesh terrain (the scan's path)."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.placement.shaft_survey import ShaftSurveyError, cast_rays, survey_shaft
from snakesim.components.terrain import load_terrain


def _angle(a, b):
    return float(np.arccos(np.clip(abs(np.dot(a, b)) / np.linalg.norm(a) / np.linalg.norm(b), -1, 1)))


def test_parallel_walls_exact():
    yaw = 0.4
    t = load_terrain({"kind": "parallel_walls", "gap": 0.3, "yaw": yaw})
    s = survey_shaft(t, (0.2, 0.05, 0.7), plus_side=(-np.sin(yaw), np.cos(yaw)))
    across = np.array([-np.sin(yaw), np.cos(yaw), 0.0])              # the channel runs along (cos yaw, sin yaw)
    assert s.width == pytest.approx(0.3, abs=1e-6) and s.chord == pytest.approx(0.3, abs=1e-6)
    np.testing.assert_allclose(s.normal, across, atol=1e-6)
    np.testing.assert_allclose(s.long, np.cross(across, [0, 0, 1]), atol=1e-6)
    np.testing.assert_allclose(s.wall_normals, [across, -across], atol=1e-6)
    assert s.roughness.max() < 1e-9 and abs(s.lean) < 1e-9
    # the centre is on the mid-plane: equidistant from both walls
    assert float(t.distance(s.centre[None])[0]) == pytest.approx(0.15, abs=1e-6)


def test_moulin_slot_width_and_axes_from_its_wall_functions():
    """At three depths: the width lies between the slot's true widths over the patch (SlotMoulin: h(t, s, ±1)
    at every patch point; the plane fit averages them), within 0.342-0.350 m (terrains/moulin-slot.yaml), the
    narrow axis along the slot's v̂ = y within the walls' 1.5 % tilt, the roughness below the modes' rms."""
    t = load_terrain("moulin-slot")
    for x, z in ((1.2, -3.5), (0.0, -2.5), (-1.5, -5.5)):
        c0 = float(t.centre(np.array([z]))[0][0])
        s = survey_shaft(t, (x, c0 + 0.03, z), patch_long=0.3, patch_height=0.3)
        tt, zz = np.meshgrid(np.linspace(x - 0.3, x + 0.3, 7), np.linspace(z - 0.3, z + 0.3, 7))
        width = t.half_width(tt.ravel(), zz.ravel(), np.ones(tt.size))[0] + \
            t.half_width(tt.ravel(), zz.ravel(), -np.ones(tt.size))[0]
        assert width.min() - 1e-4 <= s.width <= width.max() + 1e-4, (z, s.width, width.min(), width.max())
        assert 0.342 - 1e-4 <= s.width <= 0.350 + 1e-4
        assert _angle(s.narrow, [0, 1, 0]) < 1e-3          # the shortest horizontal chord: straight across
        assert _angle(s.normal, [0, 1, 0]) < np.arctan(0.015) + 2e-3
        assert _angle(s.long, [1, 0, 0]) < np.arctan(0.015) + 2e-3
        assert s.roughness.max() < 0.0015                   # the roughness modes' rms (1.5 mm) bounds it
        # the centre: the chord's mid-point on the slot's meandering mid-line, c(s) at that depth
        hp = t.half_width(np.array([x]), np.array([z]), np.array([1.0]))[0][0]
        hm = t.half_width(np.array([x]), np.array([z]), np.array([-1.0]))[0][0]
        assert s.centre[1] == pytest.approx(c0 + 0.5 * (hp - hm), abs=1e-5)


def test_mesh_slot(tmp_path):
    """Two ice slabs 0.3 m apart, turned 0.3 rad in yaw and leaning 0.03 rad, meshed with trimesh and imported
    as a mesh terrain (SDF grid at h = 2 cm). A plane's distance is linear, so the grid's trilinear
    interpolation reproduces it exactly in cells away from the slabs' edges: the survey is exact to the rays'
    stop tolerance, whatever h."""
    import trimesh

    from snakesim.components.terrain.mesh import mesh_terrain

    gap, yaw, lean = 0.3, 0.3, 0.03
    slabs = []
    for side in (-1, 1):
        b = trimesh.creation.box(extents=(1.6, 0.3, 1.6))
        b.apply_translation((0.0, side * (gap / 2 + 0.15), 0.0))
        slabs.append(b)
    mesh = trimesh.util.concatenate(slabs)
    mesh.apply_transform(trimesh.transformations.rotation_matrix(lean, (1, 0, 0)))
    mesh.apply_transform(trimesh.transformations.rotation_matrix(yaw, (0, 0, 1)))
    mesh.export(tmp_path / "slot.stl")
    t = mesh_terrain(tmp_path / "slot.stl", resolution=0.02, store=tmp_path / "store")
    across = np.array([-np.sin(yaw) * np.cos(lean), np.cos(yaw) * np.cos(lean), np.sin(lean)])
    s = survey_shaft(t, (0.05, 0.02, 0.0), plus_side=(-np.sin(yaw), np.cos(yaw)))
    assert s.width == pytest.approx(gap, abs=1e-5)
    assert s.chord == pytest.approx(gap / np.cos(lean), abs=1e-5)      # the horizontal chord crosses obliquely
    np.testing.assert_allclose(s.normal, across, atol=1e-5)
    assert s.lean == pytest.approx(lean, abs=1e-5)
    assert s.roughness.max() < 1e-5 and (s.hits == 49).all()


def test_rays_and_errors():
    t = load_terrain("parallel-walls-0.35")
    d = cast_rays(t, [[0, 0, 0], [0, 0, 0], [0, 0, 0]], [[0, 1, 0], [0, -0.6, 0.8], [1, 0, 0]])
    np.testing.assert_allclose(d[:2], [0.175, 0.175 / 0.6], atol=1e-6)
    assert d[2] == np.inf                                      # along the channel: no wall within range
    with pytest.raises(ShaftSurveyError, match="inside the terrain's solid"):
        survey_shaft(t, (0.0, 0.3, 0.0))
    with pytest.raises(ShaftSurveyError, match="no horizontal chord"):
        survey_shaft(load_terrain("flat-ice"), (0.0, 0.0, 0.5))
