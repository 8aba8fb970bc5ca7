"""Ground-truth labels (.labels): each lidar beam and camera pixel says what it hit, checked against the
geometry it lies on: in an obstacle field a beam labelled block b ends on that block's surface (its own
box coordinates), one labelled rock k on that sphere, one labelled ice on the ground; a beam on the robot
carries its link; a miss carries 0; a camera's label image is 0 exactly where its depth is NaN."""

from __future__ import annotations

import math

import numpy as np

from scenes import ROBOT, USES, all_links_at, initial_link_poses, terrain, world_at
from snakesim.components.perception import Camera, Lidar
from snakesim.components.perception.labels import NOTHING, OBSTACLE, ROBOT as ROBOT_LABEL, TERRAIN, label_name
from snakesim.components.perception.lidar import RETURN
from snakesim.components.terrain.obstacles import rpy_matrix
from snakesim.framework import Harness

BLOCK = {"center": (1.2, 0.3, 0.2), "size": (0.5, 0.4, 0.4), "yaw": 0.4}
ROCKS = [{"center": (-0.9, 0.8, -0.05), "radius": 0.35}, {"center": (0.2, -1.3, -0.1), "radius": 0.3}]
COURSE = terrain({"kind": "obstacles", "ground_height": 0.0, "boxes": [BLOCK], "spheres": ROCKS,
                  "materials": [{"name": "ice", "albedo": 0.7}, {"name": "rock", "albedo": 0.25}],
                  "regions": {"ground": "ice", "blocks": "rock", "rocks": "rock"}})
H = 1.6
DOWN = {"kind": "grid", "channels": 48, "horizontal_samples": 240, "vertical_fov": (-85.0, -20.0)}


def test_lidar_labels_lie_on_the_surfaces_they_name():
    h = Harness(Lidar, {"link": "lidar", "beams": DOWN, "max_range": 20.0}, rate=10.0, uses=USES)
    h.inputs.world = world_at(COURSE, all_links_at((0.0, 0.0, H)), extent=10.0)
    s = h.outputs()["scan"]
    assert s.label.dtype == np.uint16 and s.label.shape == s.range.shape
    ret = s.status == RETURN
    p = s.points[ret].astype(float) + [0.0, 0.0, H]                  # world: the lidar is level at (0, 0, H)
    lab = s.label[ret]
    ice, block = lab == TERRAIN + 0, lab == OBSTACLE + 0
    rocks = [lab == OBSTACLE + 1 + k for k in range(len(ROCKS))]
    assert ice.sum() > 100 and block.sum() > 20 and all(r.sum() > 20 for r in rocks)
    assert (ice | block | np.any(rocks, axis=0)).all()              # the rock material's own label never shows
    tol = 1e-4                                                       # float32 points at a few m
    assert np.abs(p[ice, 2]).max() < tol
    q = (p[block] - BLOCK["center"]) @ rpy_matrix(yaw=BLOCK["yaw"])  # block coordinates
    excess = np.abs(q) - 0.5 * np.array(BLOCK["size"])
    assert np.abs(excess.max(axis=1)).max() < tol                    # on a face, not inside or beyond
    for r, spec in zip(rocks, ROCKS):
        assert np.abs(np.linalg.norm(p[r] - spec["center"], axis=1) - spec["radius"]).max() < tol
    assert label_name(OBSTACLE + 0) == "obstacle:0" and label_name(TERRAIN, COURSE) == "terrain:ice"


def test_misses_are_nothing_and_the_robot_its_link():
    poses = initial_link_poses()
    head = ROBOT.link_index("head")
    ground = terrain({"kind": "plane", "origin": (0.0, 0.0, -1.0)})
    beams = {"kind": "grid", "channels": 2, "horizontal_samples": 1, "vertical_fov": (-90.0, 90.0),
             "horizontal_fov": 1.0}                                   # one beam down onto the head, one up
    h = Harness(Lidar, {"link": "head", "xyz": (0.125, 0.0, 0.0675 + 0.2), "beams": beams, "min_range": 0.05},
                rate=10.0, uses=USES)
    h.inputs.world = world_at(ground, poses, robot_visible=True, robot_geometry="collision")
    s = h.outputs()["scan"]
    assert s.label.tolist() == [NOTHING, ROBOT_LABEL + head]
    assert label_name(s.label[1], links=ROBOT.links) == "link:head"


def test_camera_label_image():
    down = (0.0, math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4))          # x forward turned to -z
    over = (BLOCK["center"][0], BLOCK["center"][1], H)
    c = Harness(Camera, {"link": "camera_left", "width": 80, "height": 60, "model": {"kind": "pinhole", "fov": 100.0},
                         "max_range": 5.0}, rate=5.0, uses=USES)
    c.inputs.world = world_at(COURSE, all_links_at(over, down), extent=2.0)
    f = c.outputs()["frame"]
    assert f.label.shape == f.depth.shape and f.label.dtype == np.uint16
    np.testing.assert_array_equal(f.label == NOTHING, np.isnan(f.depth))    # the course ends at 2 m: misses
    ice, block = f.label == TERRAIN, f.label == OBSTACLE
    assert ice.sum() > 100 and block.sum() > 100
    # looking straight down: the ice at depth H, the block's top at H − its height, its sides in between
    np.testing.assert_allclose(f.depth[ice], H, rtol=1e-5)
    top = H - BLOCK["size"][2]
    assert np.all((f.depth[block] >= top - 1e-5) & (f.depth[block] < H))
    assert np.mean(np.abs(f.depth[block] - top) < 1e-5) > 0.5


def test_refined_hits_keep_their_terrain_label():
    """Inside a tube (hits refined onto the exact cylinder) every return is the tube's material; a beam whose
    wall lies past max_range is nothing."""
    tube = terrain({"kind": "tube", "radius": 0.45, "axis": (1.0, 0.0, 0.0)})
    beams = {"kind": "grid", "channels": 16, "horizontal_samples": 90, "vertical_fov": (-80.0, 80.0)}
    h = Harness(Lidar, {"link": "lidar", "beams": beams, "max_range": 1.0}, rate=10.0, uses=USES)
    h.inputs.world = world_at(tube, all_links_at((2.0, 0.0, 0.0)))
    s = h.outputs()["scan"]
    ret = s.status == RETURN
    assert ret.any() and (~ret).any()                  # shallow beams reach the wall beyond 1 m
    assert np.all(s.label[ret] == TERRAIN) and np.all(s.label[~ret] == NOTHING)
