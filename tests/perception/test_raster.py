"""The ``raster`` back end (.raster): a pinhole camera's image by rasterisation gives Embree's image
of the same rays.

A camera 0.6 m above the middle of the straight robot looks down at it lying on textured ice; both
back ends render it (the robot visible: its blades' silhouettes against the ice):

- every pixel that both see: range equal to Embree's float32 rounding (Embree casts in float32 from
  the ray's start: an error ≲ a few ε₃₂ of the coordinates' size, here bound 8·ε₃₂·(|p| + r));
- labels (and hit/miss) equal except at silhouette pixels: a pixel that differs has a 4-neighbour
  whose Embree label differs from its own (its ray grazes an edge), and they are < 2 % of the image;
- shading follows: image values equal where labels are, to float32 rounding;
- a fisheye camera's rays are no pinhole grid: cast by Embree, bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from scenes import F32, USES, initial_link_poses, terrain, world_at
from snakesim.components.perception import Camera
from snakesim.components.perception.raster import RasterWorld, pinhole_grid
from snakesim.framework import Harness

LOOK_DOWN = {"link": "module_05", "optical": False, "xyz": (0.0, 0.0, 0.6), "rpy": (np.pi, 0.0, 0.0),
             "width": 96, "height": 72}


def render(world, **params):
    h = Harness(Camera, {**LOOK_DOWN, **params}, rate=5.0, uses=USES)
    h.inputs.world = world
    return h.outputs()["frame"], h


@pytest.fixture(scope="module")
def worlds():
    ice = terrain({"kind": "plane", "materials": [{"name": "ice", "texture": "checker", "texture_size": 0.05}]})
    poses = initial_link_poses()
    return (world_at(ice, poses, robot_visible=True), world_at(ice, poses, robot_visible=True, ray_caster="raster"))


def silhouette(label: np.ndarray) -> np.ndarray:
    """Pixels with a 4-neighbour of another label."""
    edge = np.zeros(label.shape, dtype=bool)
    dv, dh = label[1:] != label[:-1], label[:, 1:] != label[:, :-1]
    edge[1:] |= dv
    edge[:-1] |= dv
    edge[:, 1:] |= dh
    edge[:, :-1] |= dh
    return edge


def test_raster_image_is_embrees_but_at_silhouettes(worlds):
    embree, raster = worlds
    assert isinstance(raster, RasterWorld)
    (fe, h), (fr, _) = render(embree), render(raster)
    assert pinhole_grid(h.c._bundle) is not None
    robot = (fe.label != 0) & (fe.label != fe.label[0, 0])
    assert robot.sum() > 100 and np.isfinite(fe.range).sum() > 0.5 * fe.range.size   # the robot and the ice in view
    differ = (fe.label != fr.label) | (np.isfinite(fe.range) != np.isfinite(fr.range))
    assert np.all(silhouette(fe.label)[differ])
    assert differ.sum() < 0.02 * differ.size
    same = ~differ & np.isfinite(fe.range)
    p = np.linalg.norm(fe.pose[:3])
    assert np.all(np.abs(fr.range[same] - fe.range[same]) <= 8 * F32 * (p + fe.range[same]))
    assert np.abs(fr.image[same] - fe.image[same]).max() <= 1e-4


def test_a_fisheye_is_cast_by_embree(worlds):
    embree, raster = worlds
    fisheye = {"model": {"kind": "fisheye", "fov": 180.0}}
    (fe, h), (fr, _) = render(embree, **fisheye), render(raster, **fisheye)
    assert pinhole_grid(h.c._bundle) is None
    np.testing.assert_array_equal(fe.range, fr.range)
    np.testing.assert_array_equal(fe.label, fr.label)
