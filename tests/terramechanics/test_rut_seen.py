"""The deformed surface is what the consumers see: after a wheel has pressed a rut into the snow field,
a lidar's terrain cast (the sensors' Embree scene, rebuilt when the terrain's state version moves:
terrain/derived.py) returns the rut's depth, and the viewer's display mesh has the deformed heights at the
nodes. The reference is the terrain's state itself (base − s_p at a node, deformable_kernels.py)."""

from __future__ import annotations

import numpy as np

from snakesim.components.perception.ray_caster import EmbreeWorld, StaticTerrainScene
from snakesim.components.perception.surfaces import terrain_surfaces
from snakesim.components.terrain.derived import TerrainDerived
from snakesim.components.terrain.spec import load_terrain
from snakesim.components.terramechanics.wheel import RigidWheel, wheel_forces

WHEEL = RigidWheel(radius=0.2, width=0.1)
CELL = 0.02                      # the snow field's node spacing; its origin (−10, −10) puts nodes on k·2 cm


def rutted(terrain):
    for k in range(30):          # rolling along +x from −0.3 m, sinking 5 cm
        wheel_forces(terrain, WHEEL, (-0.3 + 0.01 * k, 0.0, WHEEL.radius - 0.05), 0.0, 0.2, commit=True)


def node_points():
    """Nodes across and along the rut (and beside it, untouched)."""
    xs = np.arange(-0.2, 0.1, CELL)
    ys = np.arange(-0.1, 0.1 + 1e-9, CELL)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    return X.ravel(), Y.ravel()


def test_a_lidar_sees_the_rut_at_its_depth():
    terrain = load_terrain("snow-field")
    scene = TerrainDerived(lambda t: StaticTerrainScene(terrain_surfaces(t, (0.0, 0.0, 0.0), 1.0, CELL)))
    x, y = node_points()
    o = np.column_stack([x, y, np.ones_like(x)])                 # beams straight down from 1 m
    d = np.tile([0.0, 0.0, -1.0], (x.size, 1))
    before = EmbreeWorld(0.0, scene.get(terrain), None, None).cast(o, d, 5.0)
    assert np.allclose(before.distance, 1.0, atol=1e-6)
    rutted(terrain)
    depth = terrain.rut_depth(x, y)
    assert depth.max() > 0.03 and (depth == 0.0).any()           # a rut, and untouched snow beside it
    after = EmbreeWorld(1.0, scene.get(terrain), None, None).cast(o, d, 5.0)
    assert scene.builds == 2                                      # rebuilt for the new state
    # float32 Embree, then refined onto the bilinear surface in float64
    np.testing.assert_allclose(after.distance, 1.0 + depth, atol=1e-6)


def test_the_display_mesh_has_the_deformed_heights():
    terrain = load_terrain("snow-field")
    rutted(terrain)
    mesh = terrain.display_mesh((0.0, 0.0, 0.0), 0.4, CELL, None)
    v = np.asarray(mesh.vertices, dtype=np.float64)
    near = np.abs(v[:, :2] / CELL - np.round(v[:, :2] / CELL)).max(axis=1) < 1e-6     # the vertices on nodes
    assert near.sum() > 100
    depth = terrain.rut_depth(v[near, 0], v[near, 1])
    assert depth.max() > 0.03
    np.testing.assert_allclose(v[near, 2], -depth, atol=1e-6)    # float32 vertices of metre-scale heights
