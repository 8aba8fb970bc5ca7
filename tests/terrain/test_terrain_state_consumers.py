"""Consumers that derive geometry from a terrain follow its state (terrain/derived.py).

A deformable kind changes ``terrain.state`` in place and calls ``state.changed()``; whatever was built
from the terrain once and kept is built again then, and only then:

- the sensors' ray-casting scene (``sensor_scene``): rays looking down at a ground whose height
  rises by dz measure ranges shorter by dz, to Embree's float32 precision;
- the viewer (``rerun_viewer``): the recording holds the ground's mesh at the first frame and again
  at the change's time, their heights dz apart; a static kind's mesh is logged once, static;
- a static kind (version 0) is drawn once however many steps run; so is a kind with state that
  does not change.

The test kind is a plugin kind (as docs/plugins.md's dome, registered as in test_terrain_kinds.py):
flat ground z = h over a 2 m square, h a one-element state array.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import pytest
from pydantic import Field

from snakesim.components.perception import SensorScene
from snakesim.components.terrain import (Bounds, KindSpec, Terrain, TerrainDerived, TerrainKind, TerrainState,
                                         load_terrain)
from snakesim.components.viz import entities as E
from snakesim.components.viz.sink import RerunSink
from snakesim.framework import Harness, hookimpl
from snakesim.framework.registry import Registry, _register_each, make_plugin_manager

HALF = 1.0          # m, half-size of the ground's square
DZ = 0.2            # m, how far the ground rises
EYE = 0.5           # m, height the rays start at
F32_RANGE = 1e-6    # m: Embree's float32 hits at ~0.5 m (≈6e-8) with margin


class GroundSpec(KindSpec):
    kind: Literal["test_ground"]
    height: float = Field(0.0, description="m, z of the ground at the start")
    deformable: bool = Field(True, description="the height is state (changes during a run)")


class Ground(Terrain):
    """Flat ground z = h over |x|, |y| <= HALF (solid below). Deformable: h is ``state.height[0]``,
    changed in place; static: h is fixed and the state empty. ``draws`` counts display meshes."""

    kind = "test_ground"

    def __init__(self, height: float = 0.0, deformable: bool = True, **kw):
        state = TerrainState(height=np.array([float(height)])) if deformable else None
        super().__init__(state=state, **kw)
        self._fixed = float(height)
        self.draws = 0

    @property
    def height(self) -> float:
        return float(self.state.height[0]) if self.state.may_change else self._fixed

    def _query(self, p):
        normal = np.broadcast_to([0.0, 0.0, 1.0], p.shape).copy()
        return p[:, 2] - self.height, normal, np.zeros(len(p), dtype=np.int64)

    def bounds(self):
        return Bounds(np.array([-HALF, -HALF, -1.0]), np.array([HALF, HALF, 1.0]))

    def display_mesh(self, center, extent, cell, cutaway):
        self.draws += 1
        return super().display_mesh(center, extent, cell, cutaway)


GROUND = TerrainKind("test_ground", GroundSpec, Ground,
                     lambda spec, ctx, **kw: Ground(spec.height, spec.deformable, **kw))


class _Plugin:
    @hookimpl
    def snakesim_register_terrain_kinds(self, registry):
        registry.add_terrain_kind(GROUND)


@pytest.fixture(scope="module")
def registry() -> Registry:
    pm = make_plugin_manager(load_entry_points=False)
    pm.register(_Plugin(), name="test_ground_plugin")
    reg = Registry(pm)
    _register_each(pm, "snakesim_register_terrain_kinds", reg)
    return reg


def ground(registry, deformable=True) -> Ground:
    return load_terrain({"kind": "test_ground", "height": 0.0, "deformable": deformable}, registry=registry)


def rise(terrain: Ground, dz: float, t: float | None = None) -> None:
    """What a deformable terrain's model does: change the state in place, then say so."""
    terrain.state.height[0] += dz
    terrain.state.changed(t)


# -- the rule ----------------------------------------------------------------------------------------

def test_derived_value_is_rebuilt_on_a_state_change_only(registry):
    terrain = ground(registry)
    heights = TerrainDerived(lambda t: t.height)
    assert [heights.get(terrain) for _ in range(3)] == [0.0, 0.0, 0.0] and heights.builds == 1
    rise(terrain, DZ)
    assert heights.stale(terrain)
    assert heights.get(terrain) == pytest.approx(DZ) and heights.get(terrain) == pytest.approx(DZ)
    assert heights.builds == 2 and heights.version == terrain.state.version == 1
    other = ground(registry)                         # another object, same version: rebuilt too
    assert heights.get(other) == 0.0 and heights.builds == 3


# -- perception: the sensors' scene -------------------------------------------------------------------

def down_ranges(scene: Harness) -> np.ndarray:
    """Ranges (m) of rays straight down from z = EYE over the ground, cast into the scene's world now."""
    xy = np.array([[0.0, 0.0], [0.3, -0.2], [-0.55, 0.45], [0.71, 0.63]])
    origins = np.column_stack([xy, np.full(len(xy), EYE)])
    down = np.tile([0.0, 0.0, -1.0], (len(xy), 1))
    hits = scene.outputs()["world"].cast(origins, down, max_range=5.0)
    assert hits.hit.all()
    return hits.distance.copy()


def test_rays_measure_the_ground_after_it_rises(registry):
    terrain = ground(registry)
    scene = Harness(SensorScene, {"extent": 2.0})
    scene.inputs.terrain = terrain
    np.testing.assert_allclose(down_ranges(scene), EYE, atol=F32_RANGE)
    down_ranges(scene)
    assert terrain.draws == 1                        # unchanged: the scene is kept
    rise(terrain, DZ)
    np.testing.assert_allclose(down_ranges(scene), EYE - DZ, atol=F32_RANGE)
    assert terrain.draws == 2                        # built again once, for the change
    down_ranges(scene)
    assert terrain.draws == 2


@pytest.mark.parametrize("deformable", [False, True], ids=["static kind", "state never changed"])
def test_an_unchanging_terrain_is_built_once(registry, deformable):
    terrain = ground(registry, deformable)
    scene = Harness(SensorScene, {"extent": 2.0})
    scene.inputs.terrain = terrain
    for _ in range(20):
        ranges = down_ranges(scene)
    np.testing.assert_allclose(ranges, EYE, atol=F32_RANGE)
    assert terrain.draws == 1 and terrain.state.version == 0


# -- the viewer ----------------------------------------------------------------------------------------

def terrain_meshes(path) -> tuple[list, list, bool]:
    """The terrain entity's meshes in an .rrd, read back with rerun's reader (as tests/viz do):
    (sim times s, vertex positions per mesh, in time order; whether a mesh was logged static)."""
    import rerun.chunk as rc

    times, vertices, static = [], [], False
    for chunk in rc.RrdReader(path).stream().to_chunks():
        if chunk.entity_path != "/" + E.TERRAIN:
            continue
        batch = chunk.to_record_batch()
        if "Mesh3D:vertex_positions" not in batch.schema.names:
            continue
        if chunk.is_static:
            static = True
            continue
        times += [d.total_seconds() for d in batch.column(E.TIMELINE).to_pylist()]
        vertices += batch.column("Mesh3D:vertex_positions").to_pylist()
    order = np.argsort(times, kind="stable")
    return [times[i] for i in order], [vertices[i] for i in order], static


def record(tmp_path, terrain, frames, change=None):
    """Drive a viewer sink at ``frames`` (s) on ``terrain``; ``change`` (t, dz): before the first frame
    at or after t the ground rises by dz at t. -> the terrain's meshes in the .rrd (terrain_meshes)."""
    path = tmp_path / "terrain.rrd"
    viewer = Harness(RerunSink, {"target": f"save {path}", "viewer_rate": 10.0})
    viewer.inputs.terrain = terrain
    for t in frames:
        if change is not None and t >= change[0]:
            rise(terrain, change[1], change[0])
            change = None
        viewer.c.update(t, None, viewer.u)           # a sink has no discrete state to hand back
    viewer.u.cache.close()
    return terrain_meshes(path)


def vertex_heights(values) -> np.ndarray:
    return np.asarray(values, dtype=float).reshape(-1, 3)[:, 2]


def test_recording_shows_the_ground_rise_at_the_change(tmp_path, registry):
    terrain = ground(registry)
    times, meshes, static = record(tmp_path, terrain, frames=[0.0, 0.1, 0.2, 0.3, 0.4], change=(0.25, DZ))
    np.testing.assert_allclose(times, [0.0, 0.25])   # the first frame, then the change's own time
    before, after = vertex_heights(meshes[0]), vertex_heights(meshes[1])
    assert len(before) > 0 and len(after) > 0
    np.testing.assert_allclose(before, 0.0, atol=1e-6)
    np.testing.assert_allclose(after, DZ, atol=1e-6)   # float32 vertices
    assert not static                                # a static mesh would hide the rise in rerun
    assert terrain.draws == 2


def test_recording_logs_a_static_terrain_once_static(tmp_path, registry):
    terrain = ground(registry, deformable=False)
    times, _, static = record(tmp_path, terrain, frames=np.arange(10) * 0.1)
    assert static and times == []
    assert terrain.draws == 1
