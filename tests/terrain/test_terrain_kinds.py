"""Terrain kinds enter through the plugin hook, and every consumer works from the Terrain's own methods.

- the built-in kinds are registered through ``snakesim_register_terrain_kinds`` (components/plugin.py),
  in the order the schema's messages list them;
- a kind a test plugin registers loads from YAML, is named in the unknown-kind message, and two plugins
  registering one name is an error naming both;
- a kind that implements only ``_query`` gets a display mesh on its surface (viewer, sensors), the hull
  back end's triangles, the generic refinement and no plane fast path;
- state: a deformable kind changes its state in place during a run, the contact sees the change and
  does not rebind (``use_terrain`` runs once per terrain object).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import pytest
from pydantic import Field

from snakesim.components.contact.body_contact import BodyContact
from snakesim.components.contact.hull.terrain_geometry import terrain_parts
from snakesim.components.multibody import Multibody
from snakesim.components.perception.surfaces import terrain_surfaces
from snakesim.components.terrain import (Bounds, KindSpec, PlaneTerrain, Terrain, TerrainKind, TerrainState,
                                         load_terrain, terrain_kinds)
from snakesim.components.viz.terrain_geometry import terrain_mesh
from snakesim.framework import ConfigError, hookimpl
from snakesim.framework.harness import Harness
from snakesim.framework.registry import Registry, make_plugin_manager


class BallSpec(KindSpec):
    kind: Literal["test_ball"]
    radius: float = Field(gt=0)


class Ball(Terrain):
    """A solid ball of radius r at the origin: exact distance |p| − r."""

    kind = "test_ball"

    def __init__(self, radius, **kw):
        super().__init__(**kw)
        self.radius = float(radius)

    def _query(self, p):
        r = np.linalg.norm(p, axis=1)
        return r - self.radius, p / np.maximum(r, 1e-300)[:, None], np.zeros(len(p), dtype=np.int64)

    def bounds(self):
        return Bounds(np.full(3, -self.radius), np.full(3, self.radius))


BALL = TerrainKind("test_ball", BallSpec, Ball, lambda spec, ctx, **kw: Ball(spec.radius, **kw))


class _Plugin:
    def __init__(self, *kinds):
        self.kinds = kinds

    @hookimpl
    def snakesim_register_terrain_kinds(self, registry):
        for kind in self.kinds:
            registry.add_terrain_kind(kind)


def registry_with(*plugins) -> Registry:
    pm = make_plugin_manager(load_entry_points=False)
    for i, plugin in enumerate(plugins):
        pm.register(plugin, name=f"test_plugin_{i}")
    reg = Registry(pm)
    from snakesim.framework.registry import _register_each

    _register_each(pm, "snakesim_register_terrain_kinds", reg)
    return reg


def test_built_in_kinds_come_through_the_hook_in_schema_order():
    assert list(terrain_kinds())[:8] == ["plane", "tube", "parallel_walls", "u_channel", "moulin", "dem",
                                         "obstacles", "mesh"]
    assert terrain_kinds()["plane"].terrain is PlaneTerrain


def test_a_plugin_kind_loads_and_is_named_where_kinds_are_listed():
    reg = registry_with(_Plugin(BALL))
    ball = load_terrain({"kind": "test_ball", "radius": 0.5}, registry=reg)
    assert isinstance(ball, Ball) and ball.radius == 0.5
    np.testing.assert_allclose(ball.query([[0.0, 0.0, 2.0]]).distance, [1.5])
    with pytest.raises(ConfigError, match="unknown key 'raduis'; did you mean 'radius'"):
        load_terrain({"kind": "test_ball", "raduis": 0.5}, registry=reg)
    with pytest.raises(ConfigError, match="expected tags: 'plane', .*'mesh', .*'test_ball'"):
        load_terrain({"kind": "test_bal"}, registry=reg)
    with pytest.raises(ConfigError, match="does not match any of the expected tags"):
        load_terrain({"kind": "test_ball", "radius": 0.5})          # not installed: not a kind


def test_two_plugins_registering_one_kind_is_an_error_naming_both():
    other = TerrainKind("test_ball", BallSpec, Ball, lambda spec, ctx, **kw: Ball(2 * spec.radius, **kw))
    reg = registry_with(_Plugin(BALL), _Plugin(other))
    both = r"test_ball.*more than one plugin \(test_plugin_\d: .*Ball; test_plugin_\d: .*Ball\)"
    with pytest.raises(ConfigError, match=both):
        load_terrain({"kind": "test_ball", "radius": 0.5}, registry=reg)
    load_terrain({"kind": "plane"}, registry=reg)                  # the other kinds still load


def test_a_kind_needs_its_name_as_the_spec_s_kind():
    with pytest.raises(TypeError, match="kind: Literal\\['other'\\]"):
        TerrainKind("other", BallSpec, Ball, BALL.build)


def test_a_query_only_kind_works_for_every_consumer():
    ball = Ball(0.5)
    mesh = terrain_mesh(ball, extent=2.0, cell=0.05)               # viewer
    v = mesh.vertices.astype(float)
    assert len(mesh.faces) > 500
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 0.5, atol=1e-6)
    centroids = v[mesh.faces].mean(axis=1)
    face_n = np.cross(v[mesh.faces[:, 1]] - v[mesh.faces[:, 0]], v[mesh.faces[:, 2]] - v[mesh.faces[:, 0]])
    assert (np.einsum("ij,ij->i", face_n, centroids) > 0).all()   # wound to face free space
    s = terrain_surfaces(ball, extent=2.0, cell=0.05)             # sensors: refined onto the sphere
    assert s.refine.any() and ball.refiner() is None and ball.refine_hits
    (part,) = terrain_parts(ball, extent=2.0, resolution=0.05)    # hull back end
    assert part.triangles and part.geom.num_tris == len(mesh.faces)
    assert ball.fast_plane() is None                               # the SDF contact queries it


class Deformable(Terrain):
    """A horizontal plane whose height is state: z = state.height[0]."""

    kind = "test_deformable"

    def __init__(self, **kw):
        super().__init__(state=TerrainState(height=np.zeros(1)), **kw)

    def _query(self, p):
        n = np.broadcast_to([0.0, 0.0, 1.0], p.shape)
        return p[:, 2] - self.state.height[0], np.array(n), np.zeros(len(p), dtype=np.int64)


def test_state_changes_in_place_reach_the_contact_without_rebinding(monkeypatch):
    urdf = """<robot name="body"><link name="body">
      <inertial><mass value="2.0"/><inertia ixx="0.01" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial>
      <collision><geometry><box size="0.3 0.1 0.05"/></geometry></collision></link></robot>"""
    terrain = Deformable(materials=[PlaneTerrain().materials[0]])
    assert PlaneTerrain().state.names == () and PlaneTerrain().state.version == 0      # static kinds
    mb = Harness(Multibody, {"urdf": urdf, "base_position": (0.0, 0.0, 0.0249)})
    bc = Harness(BodyContact, {}, uses={"robot": mb.c.robot})
    calls = []
    cache_cls = type(bc.u.cache)
    bind = cache_cls.use_terrain
    monkeypatch.setattr(cache_cls, "use_terrain", lambda self, comp, t: (calls.append(t), bind(self, comp, t)))
    bc.inputs.terrain = terrain
    o = mb.outputs()
    bc.inputs.link_poses, bc.inputs.link_velocities = o["link_poses"], o["link_velocities"]
    before = float(bc.outputs()["normal_force"][0])
    terrain.state.height[0] = 0.001               # the ground rises 1 mm, in place
    terrain.state.changed()
    after = float(bc.outputs()["normal_force"][0])
    assert terrain.state.version == 1
    assert after > before > 0.0                   # deeper in the ground: more force
    assert calls == [terrain]                     # bound once, for the object
