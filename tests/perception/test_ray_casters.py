"""Ray-casting back ends: the ``RayCaster`` protocol is the sensors' port type, and sensor_scene's
``ray_caster`` parameter picks a back end registered through ``snakesim_register_ray_casters``.

- embree is the built-in back end; a name nobody registered is an error naming the valid ones
  (from Python, and from a scene file with its file and key); two plugins registering one name is
  an error naming both;
- back ends a test plugin registers are picked by the parameter: a wrapper that counts calls and
  delegates to Embree gives the lidar's scan and the camera's image bit for bit, a brute-force NumPy
  caster over the same triangles the lidar's scan to round-off (the sensors call only the protocol);
- wiring checks the protocol: a component declaring ``Input(type=RayCaster)`` wires to sensor_scene,
  another back end's world class (not Embree's) is accepted there, a class without ``cast_from`` is not.
"""

from __future__ import annotations

import collections

import numpy as np
import pytest

from scenes import ROBOT, USES, all_links_at, initial_link_poses, terrain, world_at
from snakesim.components.multibody.pose_quaternions import rotation_matrices
from snakesim.components.perception import (Camera, EmbreeWorld, Lidar, RayCaster, RayCasterBackend, RayHits,
                                            SensorScene, ray_casters)
from snakesim.components.perception.ray_caster import EMBREE, RobotScenes, StaticTerrainScene
from snakesim.components.perception.ray_casting import ray_caster_backend
from snakesim.components.terrain import TerrainSource
from snakesim.framework import Builder, BuildError, Component, ConfigError, Harness, Input, Output, Params, hookimpl
from snakesim.framework.registry import Registry, _register_each, make_plugin_manager

GRID = {"kind": "grid", "channels": 16, "horizontal_samples": 90, "vertical_fov": (-80.0, 10.0)}
CALLS = collections.Counter()


class CountingWorld:
    """Embree's world behind a wrapper that counts the sensors' calls (no subclass of anything)."""

    def __init__(self, t, terrain_scene, robot_scenes, link_poses):
        self.inner = EmbreeWorld(t, terrain_scene, robot_scenes, link_poses)

    def link_pose(self, row):
        return self.inner.link_pose(row)

    def cast(self, origins, directions, max_range, min_range=0.0):
        CALLS["cast"] += 1
        return self.inner.cast(origins, directions, max_range, min_range)

    def cast_from(self, R, p, origins, directions, max_range, min_range=0.0, bundle=None, buffers=None, exact=True,
                  refine_beyond=0.0):
        CALLS["cast_from"] += 1
        return self.inner.cast_from(R, p, origins, directions, max_range, min_range, bundle, buffers, exact,
                                    refine_beyond)


class BruteWorld:
    """Every ray against every terrain triangle (Möller–Trumbore in float64; flat faces, the robot
    not visible): what another back end looks like to the sensors."""

    def __init__(self, t, surfaces, robot, link_poses):
        self.t, self.surfaces, self.link_poses = t, surfaces, link_poses
        v = surfaces.vertices[surfaces.faces].astype(np.float64)
        self.a, self.e1, self.e2 = v[:, 0], v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
        n = np.cross(self.e1, self.e2)
        self.n = n / np.linalg.norm(n, axis=1, keepdims=True)

    def link_pose(self, row):
        q = self.link_poses[row:row + 1, 3:7]
        return rotation_matrices(q)[0], self.link_poses[row, :3]

    def cast(self, origins, directions, max_range, min_range=0.0):
        return self.cast_from(np.eye(3), np.zeros(3), origins, directions, max_range, min_range)[0]

    def cast_from(self, R, p, origins, directions, max_range, min_range=0.0, bundle=None, buffers=None, exact=True,
                  refine_beyond=0.0):
        o_w = np.asarray(origins, dtype=float) @ np.asarray(R).T + p
        d_w = np.asarray(directions, dtype=float) @ np.asarray(R).T
        s = o_w + min_range * d_w
        pv = np.cross(d_w[:, None, :], self.e2[None])                        # (n, m, 3)
        det = np.einsum("nmk,mk->nm", pv, self.e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            tv = s[:, None, :] - self.a[None]
            u = np.einsum("nmk,nmk->nm", tv, pv) * inv
            qv = np.cross(tv, self.e1[None])
            w = np.einsum("nk,nmk->nm", d_w, qv) * inv
            t = np.einsum("nmk,mk->nm", qv, self.e2) * inv
        ok = (np.abs(det) > 1e-12) & (u >= 0) & (w >= 0) & (u + w <= 1) & (t > 0) & (t <= max_range - min_range)
        t = np.where(ok, t, np.inf)
        face = t.argmin(axis=1)
        rows = np.arange(len(s))
        distance = min_range + t[rows, face]
        normal = self.n[face] * -np.sign(np.einsum("ij,ij->i", self.n[face], d_w))[:, None]
        hits = RayHits(distance, normal, self.surfaces.albedo[face].astype(float),
                       self.surfaces.color[face].astype(float), np.full(len(s), -1, dtype=np.int64))
        return hits, o_w, d_w


COUNTING = RayCasterBackend("test_counting", terrain=StaticTerrainScene, robot=RobotScenes, world=CountingWorld)
BRUTE = RayCasterBackend("test_brute", terrain=lambda surfaces, refine_limit: surfaces, robot=lambda s: s,
                         world=BruteWorld)


class _Plugin:
    def __init__(self, *backends):
        self.backends = backends

    @hookimpl
    def snakesim_register_ray_casters(self, registry):
        for backend in self.backends:
            registry.add_ray_caster(backend)


def registry_with(*plugins) -> Registry:
    pm = make_plugin_manager(load_entry_points=False)
    for i, plugin in enumerate(plugins):
        pm.register(plugin, name=f"test_plugin_{i}")
    reg = Registry(pm)
    _register_each(pm, "snakesim_register_ray_casters", reg)
    return reg


@pytest.fixture
def installed(monkeypatch):
    """The test back ends registered as an installed plugin's would be."""
    reg = registry_with(_Plugin(COUNTING, BRUTE))
    monkeypatch.setattr("snakesim.framework.registry.default_ray_casters", lambda: reg)
    return reg


def lidar_scan(world, **params):
    h = Harness(Lidar, {"link": "lidar", "beams": GRID, "max_range": 20.0, **params}, rate=10.0, uses=USES)
    h.inputs.world = world
    return h.outputs()["scan"]


def camera_frame(world):
    h = Harness(Camera, {"link": "lidar", "width": 48, "height": 32, "light": {"kind": "sun", "shadows": True}},
                rate=5.0, uses=USES)
    h.inputs.world = world
    return h.outputs()["frame"]


def test_embree_is_the_built_in_back_end_and_the_default():
    assert list(ray_casters())[0] == "embree" and ray_casters()["embree"] is EMBREE
    assert SensorScene.Params().ray_caster == "embree"
    world = world_at(terrain({"kind": "plane"}), all_links_at((0.0, 0.0, 1.0)))
    assert isinstance(world, EmbreeWorld) and isinstance(world, RayCaster)


def test_an_unknown_back_end_is_an_error_naming_the_valid_ones(installed, tmp_path):
    with pytest.raises(ValueError, match="ray_caster = 'optix' is not a registered ray-casting back end; "
                                         "valid: embree, raster, test_counting, test_brute"):
        Harness(SensorScene, {"ray_caster": "optix"}, uses=USES)
    scene = tmp_path / "scene.yaml"
    scene.write_text("sim: {duration: 0.01, dt: 0.001}\ncomponents:\n"
                     "  scene: {type: sensor_scene, params: {ray_caster: optix}}\n")
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import build_registry
    from snakesim.framework.session import Session

    reg = build_registry(load_entry_points=False)
    with pytest.raises(ConfigError,
                       match=r"scene\.yaml:3.*ray_caster.*valid: embree, raster, test_counting, test_brute"):
        Session(resolve(str(scene), search_path=reg.assembly_paths()), reg)


def test_two_plugins_registering_one_name_is_an_error_naming_both():
    other = RayCasterBackend("test_counting", terrain=StaticTerrainScene, robot=RobotScenes, world=EmbreeWorld)
    reg = registry_with(_Plugin(COUNTING), _Plugin(other))
    with pytest.raises(ValueError, match=r"test_counting.*more than one plugin \(test_plugin_\d: .*; test_plugin_\d"):
        ray_caster_backend("test_counting", reg)
    assert ray_caster_backend("embree", reg) is EMBREE
    with pytest.raises(TypeError, match="world is not callable"):
        RayCasterBackend("test_bad", terrain=StaticTerrainScene, robot=RobotScenes, world=None)


def test_a_registered_back_end_is_picked_and_sees_what_embree_sees(installed):
    ground = terrain({"kind": "plane", "tilt": 0.2, "azimuth": 0.7})
    poses = initial_link_poses() + np.r_[0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.0]
    embree = world_at(ground, poses, robot_visible=True)
    counting = world_at(ground, poses, robot_visible=True, ray_caster="test_counting")
    assert isinstance(counting, CountingWorld) and isinstance(counting, RayCaster)
    CALLS.clear()
    a, b = lidar_scan(embree), lidar_scan(counting)
    assert CALLS["cast_from"] == 1
    assert (a.status == 0).any() and (a.status != 0).any()         # the robot and the plane both in view
    for field in ("range", "intensity", "points", "status"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    fa, fb = camera_frame(embree), camera_frame(counting)
    assert CALLS["cast_from"] == 2 and CALLS["cast"] == 1            # the image, then its shadow rays
    for field in ("image", "depth", "range"):
        np.testing.assert_array_equal(getattr(fa, field), getattr(fb, field))


@pytest.mark.parametrize("spec, position", [({"kind": "plane", "tilt": 0.2, "azimuth": 0.7}, (0.4, -0.2, 1.3)),
                                            ({"kind": "parallel_walls", "gap": 1.0}, (0.0, 0.1, 0.5))])
def test_a_brute_force_back_end_gives_embree_s_scan_to_round_off(installed, spec, position):
    ground = terrain(spec)
    poses = all_links_at(position)
    embree = world_at(ground, poses, extent=40.0)
    brute = world_at(ground, poses, extent=40.0, ray_caster="test_brute")
    assert isinstance(brute, BruteWorld)
    a, b = lidar_scan(embree), lidar_scan(brute)
    np.testing.assert_array_equal(a.status, b.status)
    assert (a.status == 0).sum() > len(a.status) // 4
    ret = a.status == 0
    # Embree casts in float32: ≈1e-7 of the coordinates (up to ~20 m)
    np.testing.assert_allclose(b.range[ret], a.range[ret], rtol=0, atol=2e-5)
    np.testing.assert_allclose(b.points[ret], a.points[ret], rtol=0, atol=2e-5)
    np.testing.assert_allclose(b.intensity[ret], a.intensity[ret], rtol=1e-5, atol=1e-7)


class _ProbeParams(Params):
    pass


class _Probe(Component[_ProbeParams]):
    """Casts one ray straight down from 1 m above the origin: reads only the protocol."""

    type_name = "test_probe"
    world = Input(type=RayCaster)
    down = Output(shape=(1,), unit="m", feedthrough=True)

    def output(self, t, x, u, y):
        y.down[0] = u.world.cast(np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, -1.0]]), 10.0).distance[0]


class _OtherScene(Component[_ProbeParams]):
    """A scene component of another back end: its output's class implements the protocol."""

    type_name = "test_other_scene"
    world = Output(type=CountingWorld, feedthrough=True)

    def output(self, t, x, u, y):
        y.world = CountingWorld(t, None, None, None)


class _NotACaster:
    def cast(self, origins, directions, max_range, min_range=0.0): ...


class _BadScene(_OtherScene):
    type_name = "test_bad_scene"
    world = Output(type=_NotACaster, feedthrough=True)


def test_the_protocol_is_the_port_type():
    b = Builder(dt=1e-3, duration=0.002)
    ground = b.add(TerrainSource("terrain", spec={"kind": "plane"}))
    scene = b.add(SensorScene("scene", extent=5.0))
    probe = b.add(_Probe("probe"))
    b.connect(ground.out.terrain, scene.inp.terrain)
    b.connect(scene.out.world, probe.inp.world)
    b.record(probe.out.down)
    sim = b.build()
    sim.step(1)
    np.testing.assert_allclose(sim.value(probe.out.down), [1.0], atol=1e-6)
    assert SensorScene.outputs["world"].signal.cls is RayCaster
    assert Lidar.inputs["world"].signal.cls is RayCaster and Camera.inputs["world"].signal.cls is RayCaster

    b = Builder(dt=1e-3, duration=0.002)
    other, probe = b.add(_OtherScene("other")), b.add(_Probe("probe"))
    b.connect(other.out.world, probe.inp.world)               # another back end's world: accepted
    b.record(probe.out.down)
    b.build()

    b = Builder(dt=1e-3, duration=0.002)
    bad, probe = b.add(_BadScene("bad")), b.add(_Probe("probe"))
    b.connect(bad.out.world, probe.inp.world)
    b.record(probe.out.down)
    with pytest.raises(BuildError, match="structured _NotACaster.*structured RayCaster.*structured types differ"):
        b.build()
