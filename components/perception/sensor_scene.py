"""The physical scene the perception sensors see, once per instant (a ``RayCaster``).

Every camera and lidar casts against the output of one ``sensor_scene``: the terrain
(built into an Embree scene on the first step of a run, kept for the run and built again when
the terrain's state changes: a deformable kind's ``state.version``, terrain/derived.py) and the robot's
link meshes at the current link poses (one Embree scene per link in its own frame, built on
the first step and kept: rays are moved into the links' frames, nothing is rebuilt per
instant; see .ray_caster). Evaluating it when no sensor samples costs a copy of the link
poses. ``ray_caster`` names the back end that builds and casts (``embree``, the default;
others register through the hook ``snakesim_register_ray_casters``: .ray_casting).

    scene: {type: sensor_scene, params: {extent: 30}}
    connections: [terrain.terrain -> scene.terrain, robot.link_poses -> scene.link_poses,
                  scene.world -> lidar.world, scene.world -> camera.world]

in   terrain   Terrain (optional: without it only the robot is visible)
     link_poses[nl, 7]   x, y, z m, qx, qy, qz, qw (world), the multibody's
out  world     RayCaster at this instant (feedthrough)
uses robot: RobotModel (optional): the link meshes (its URDF visuals)
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.port_roles import LINK_POSES
from snakesim.components.terrain import Terrain, TerrainDerived
from snakesim.framework import Component, Input, Output, Params, Uses

from .ray_casting import DEFAULT_RAY_CASTER, RayCaster, ray_caster_backend
from .surfaces import robot_surfaces, terrain_surfaces

Vec3 = tuple[float, float, float]


class SensorSceneParams(Params):
    center: Vec3 = Field((0.0, 0.0, 0.0), description="m, world point the terrain is built around")
    extent: float = Field(30.0, gt=0, description="m, half-size of the terrain built around center "
                                                  "(unbounded kinds): beyond it sensors see nothing")
    cell: float = Field(0.1, gt=0, description="m, tessellation of curved analytic terrains (hits are "
                                               "refined onto the exact surface)")
    refine: bool = Field(True, description="refine hits on curved analytic terrains onto the exact surface "
                                           "(off: the tessellation at cell, faster on costly kinds such as "
                                           "the moulin)")
    refine_limit: float = Field(0.5, gt=0, description="m, largest refinement step accepted")
    robot_visible: bool = Field(True, description="the robot's own bodies occlude and return (self-occlusion)")
    robot_geometry: Literal["visual", "collision"] = Field(
        "visual", description="what sensors see of the robot: its URDF visuals (screw blades: ~23k faces on "
                              "EELS 1.0) or its collision shapes (screw envelopes: ~3k faces)")
    robot_albedo: float | None = Field(None, ge=0, le=1, description="albedo of every link (None: the "
                                                                      "mean of each visual's URDF colour)")
    ray_caster: str = Field(DEFAULT_RAY_CASTER, description="the ray-casting back end (embree, or one a plugin "
                                                            "registers)")

    @field_validator("ray_caster")
    @classmethod
    def _registered(cls, name):
        ray_caster_backend(name)          # a ValueError naming the registered back ends
        return name


class SensorScene(Component[SensorSceneParams]):
    type_name = "sensor_scene"
    robot = Uses(RobotModel, required=False, doc="the link meshes")

    terrain = Input(type=Terrain, required=False)
    link_poses = Input(shape=lambda c: (c.nl, 7), unit=None, default=0.0, role=LINK_POSES)
    world = Output(type=RayCaster, feedthrough=True, doc="the physical scene at this instant")

    def setup(self):
        self.backend = ray_caster_backend(self.p.ray_caster)
        self.nl = self.robot.nl if self.robot is not None else 0
        self._surfaces = self._robot_scenes = None
        if self.robot is not None and self.p.robot_visible:
            self._surfaces = robot_surfaces(self.robot, self.p.robot_albedo, self.p.robot_geometry)

    def make_cache(self, x, u, y):
        """This run's terrain scene: built by the back end on the first step, again when the terrain's
        state changes (a deformable kind: terrain/derived.py), never for a static kind."""
        return TerrainDerived(self._terrain_scene)

    def _terrain_scene(self, terrain: Terrain):
        p = self.p
        return self.backend.terrain(terrain_surfaces(terrain, p.center, p.extent, p.cell, p.refine), p.refine_limit)

    def output(self, t, x, u, y):
        terrain = u.terrain
        scene = u.cache.get(terrain) if terrain is not None else None
        if self._surfaces is not None and self._robot_scenes is None:
            self._robot_scenes = self.backend.robot(self._surfaces)       # once per component: static
        y.world = self.backend.world(t, scene, self._robot_scenes, u.link_poses.copy() if self.nl else None)
