"""What the sensors measure, in the viewer: a lidar's returns and a camera's image, depth and pinhole
under world/sensors/<comp>/<port>, each sample logged once at its own time, read back from the .rrd.

The scene: an EELS 1.0 (2 modules and the head) without gravity 0.3 m above a flat plane,
pitching its head up at 0.6 rad/s about the tail, so the lidar (10 Hz) sees less ground sample
by sample; a 64×48 camera at 5 Hz on the nose. The viewer runs at ~30 Hz. The robot is not
visible to its sensors here, so every return lies on the plane (motion distortion off: the logged
points are in the lidar frame at the sample's pose, which a distorted beam's is not).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.components.perception.camera_models import CahvorModel, FisheyeModel, PinholeModel
from snakesim.components.viz import entities as E
from snakesim.components.viz.attach import attach_viewer
from snakesim.components.viz.sensor_log import display_image, intrinsics
from snakesim.components.viz.target import VizTarget
from snakesim.framework.assembly import resolve
from snakesim.framework.registry import build_registry
from snakesim.framework.session import Session

W, H = 64, 48
LIDAR_HZ, CAMERA_HZ = 10.0, 5.0
HEIGHT = 0.3              # m, the robot's start height above the plane z = 0
SCENE = f"""
sim: {{duration: 0.5, dt: 0.001, integrator: semi_implicit_euler}}
components:
  terrain: {{type: terrain, params: {{spec: {{kind: plane}}}}}}
  robot:
    type: multibody
    params: {{design: eels-1.0, modules: 2, head: true, gravity: [0, 0, 0],
             base_position: [0, 0, {HEIGHT}], base_velocity: [0, 0, 0, 0, -0.6, 0]}}
  scene: {{type: sensor_scene, params: {{extent: 10, robot_visible: false}}}}
  lidar:
    type: lidar
    rate: {LIDAR_HZ}
    params: {{beams: {{kind: grid, channels: 8, horizontal_samples: 64, vertical_fov: [-30, 10]}},
             motion_distortion: false}}
  cam: {{type: camera, rate: {CAMERA_HZ}, params: {{width: {W}, height: {H}, model: {{kind: pinhole, fov: 90}}}}}}
connections:
  - terrain.terrain -> scene.terrain
  - robot.link_poses -> scene.link_poses
  - scene.world -> lidar.world
  - scene.world -> cam.world
record: [lidar.returns]
"""
POINTS = "/" + E.sensor_path("lidar.scan") + "/" + E.SENSOR_POINTS
IMAGE = "/" + E.sensor_path("cam.frame") + "/" + E.SENSOR_IMAGE
DEPTH = "/" + E.sensor_path("cam.frame") + "/" + E.SENSOR_DEPTH
PINHOLE = "/" + E.sensor_path("cam.frame") + "/" + E.SENSOR_PINHOLE


@pytest.fixture(scope="module")
def viewed(tmp_path_factory):
    """One run of the scene with the viewer attached as --viz does, saving to an .rrd."""
    d = tmp_path_factory.mktemp("sensors")
    (d / "scene.yaml").write_text(SCENE)
    reg = build_registry()
    r = resolve(str(d / "scene.yaml"), search_path=reg.assembly_paths())
    found = attach_viewer(r, VizTarget("save", str(d / "s.rrd")), reg)
    result = Session(r, reg).run()
    return found, result, d / "s.rrd"


def frame_times(rec) -> np.ndarray:
    """The viewer's frame times: when it plotted the recorded signal."""
    t, _ = rec.columns("/" + E.series_path("lidar.returns"), "Scalars:scalars")
    return t


def sample_times(rate: float, until: float) -> np.ndarray:
    """A sensor's sample times up to the viewer's last frame."""
    return np.arange(0.0, until + 1e-9, 1.0 / rate)


def test_the_viewer_wires_every_sensor_output_by_role(viewed):
    found, _, _ = viewed
    assert found.sensors == ["lidar.scan", "cam.frame"]
    for ref in found.sensors:
        assert not E.is_physical(E.sensor_path(ref)) and E.sensor_path(ref).startswith(E.SENSORS + "/")
    for path in (POINTS, IMAGE, DEPTH, PINHOLE):
        assert not E.is_physical(path)


def test_each_scan_is_logged_once_at_its_time_with_every_return(viewed, read_rrd):
    _, result, path = viewed
    rec = read_rrd(path)
    t, pts = rec.columns(POINTS, "Points3D:positions")
    np.testing.assert_allclose(t, sample_times(LIDAR_HZ, frame_times(rec)[-1]), atol=1e-9)
    # as many points as the scan had returns (recorded every step: the row at the sample time)
    steps = result["t"]
    returns = result["lidar.returns"][:, 0]
    counts = [len(p) for p in pts]
    expected = [returns[np.argmin(np.abs(steps - ti))] for ti in t]
    assert counts == expected and len(set(counts)) > 1, "the pitching lidar should see less ground each scan"
    _, colors = rec.columns(POINTS, "Points3D:colors")
    assert [len(c) for c in colors] == counts                  # one intensity colour per point


def test_scan_points_in_the_logged_lidar_frame_lie_on_the_plane(viewed, read_rrd):
    from scipy.spatial.transform import Rotation

    rec = read_rrd(viewed[2])
    t, pts = rec.columns(POINTS, "Points3D:positions")
    tt, trans = rec.columns("/" + E.sensor_path("lidar.scan"), "Transform3D:translation")
    _, quat = rec.columns("/" + E.sensor_path("lidar.scan"), "Transform3D:quaternion")
    np.testing.assert_allclose(tt, t)                          # the pose of each sample, at its time
    for p, o, q in zip(pts, trans, quat):
        world = Rotation.from_quat(np.reshape(q, 4)).apply(np.reshape(p, (-1, 3))) + np.reshape(o, 3)
        np.testing.assert_allclose(world[:, 2], 0.0, atol=1e-4)     # float32 in the recording


def test_camera_image_depth_and_pinhole_at_its_rate(viewed, read_rrd):
    rec = read_rrd(viewed[2])
    expected = sample_times(CAMERA_HZ, frame_times(rec)[-1])
    t, fmt = rec.columns(IMAGE, "Image:format")
    np.testing.assert_allclose(t, expected, atol=1e-9)
    assert all((f[0]["width"], f[0]["height"]) == (W, H) for f in fmt)
    td, dfmt = rec.columns(DEPTH, "DepthImage:format")
    np.testing.assert_allclose(td, expected, atol=1e-9)
    assert all((f[0]["width"], f[0]["height"]) == (W, H) for f in dfmt)
    assert {"Pinhole:resolution", "Pinhole:image_from_camera", "Pinhole:camera_xyz"} <= rec.static_columns(PINHOLE)
    row = next(c.to_record_batch().to_pylist()[0] for c in rec.chunks if c.entity_path == PINHOLE and c.is_static)
    assert row["Pinhole:resolution"] == [[W, H]]
    f = (W / 2) / math.tan(math.radians(45.0))                  # fov 90°
    K = np.reshape(row["Pinhole:image_from_camera"], (3, 3)).T  # stored column-major
    np.testing.assert_allclose(K, [[f, 0, (W - 1) / 2], [0, f, (H - 1) / 2], [0, 0, 1]], rtol=1e-6)


def test_the_first_image_shows_ground_below_the_horizon_only(viewed, read_rrd):
    """Level at t = 0, 0.3 m up: the lower half sees the plane (depth ~ 0.3 m·f/(v − cy) there), the
    upper half nothing (depth 0, black): the optical frame is y down, the image not flipped."""
    rec = read_rrd(viewed[2])
    _, buf = rec.columns(DEPTH, "DepthImage:buffer")
    depth = np.frombuffer(np.asarray(buf[0][0], dtype=np.uint8).tobytes(), dtype=np.float32).reshape(H, W)
    _, ibuf = rec.columns(IMAGE, "Image:buffer")
    image = np.asarray(ibuf[0][0], dtype=np.uint8).reshape(H, W)
    top, bottom = slice(0, H // 2 - 2), slice(H // 2 + 2, H)
    assert np.all(depth[top] == 0) and np.all(image[top] == 0)
    assert np.all(depth[bottom] > 0) and np.all(image[bottom] > 0)
    assert np.all(np.diff(depth[bottom, W // 2]) < 0)          # nearer towards the bottom row


def test_frustum_intrinsics_of_each_kind_of_model():
    pin = PinholeModel(W, H, 40.0, 42.0, 30.0, 25.0)
    np.testing.assert_array_equal(intrinsics(pin), [[40.0, 0, 30.0], [0, 42.0, 25.0], [0, 0, 1]])
    # an equidistant fisheye has a K, but not a pinhole's: its frustum comes from its fields of view
    fish = FisheyeModel.from_fov(W, H, 120.0)
    K = intrinsics(fish)
    np.testing.assert_allclose(K[0, 0], (W / 2) / math.tan(math.radians(60.0)))
    np.testing.assert_allclose(K[1, 1], (H / 2) / math.tan(fish.vertical_fov / 2))
    np.testing.assert_allclose(K[:2, 2], [(W - 1) / 2, (H - 1) / 2])
    # a wider-than-180° fisheye still gets a finite frustum
    assert np.all(np.isfinite(intrinsics(FisheyeModel.from_fov(W, H, 200.0))))
    cahvor = CahvorModel(W, H, (0, 0, 0), (0, 0, 1), (40.0, 0, 31.5), (0, 40.0, 23.5), (0, 0, 1), (0, 0.05, 0))
    assert cahvor.camera_info() is None
    K = intrinsics(cahvor)
    np.testing.assert_allclose(K[0, 0], (W / 2) / math.tan(cahvor.horizontal_fov / 2))


def test_linear_images_are_saturated_to_8_bits():
    import rerun as rr

    img = display_image(rr, np.array([[-0.5, 0.5, 2.0, np.nan]], dtype=np.float32))
    buf = np.asarray(img.buffer.as_arrow_array().to_pylist()[0], dtype=np.uint8)
    np.testing.assert_array_equal(buf, [0, 128, 255, 0])


def test_filters_and_stereo_pairs_are_found_by_role(tmp_path):
    reg = build_registry()
    (tmp_path / "scene.yaml").write_text(SCENE.replace("  cam:", """  pair: {type: stereo_camera, rate: 5, params: {width: 8, height: 6}}
  gamma: {type: gamma}
  cam:""").replace("  - scene.world -> cam.world", """  - scene.world -> cam.world
  - scene.world -> pair.world
  - pair.left -> gamma.frame_in"""))
    r = resolve(str(tmp_path / "scene.yaml"), search_path=reg.assembly_paths())
    found = attach_viewer(r, VizTarget("save", str(tmp_path / "f.rrd")), reg)
    assert found.sensors == ["lidar.scan", "pair.left", "pair.right", "gamma.frame", "cam.frame"]
    wired = {(s, d) for s, d, _ in r.connections}
    assert all((ref, f"viz.sensor{i}") in wired for i, ref in enumerate(found.sensors))
    assert r.components["viz"].params["sensors"] == found.sensors


def test_sensor_paths_nest_included_components_and_are_not_physical():
    assert E.sensor_path("stereo.left") == "world/sensors/stereo/left"
    assert E.sensor_path("module/3/lidar.scan") == "world/sensors/module/3/lidar/scan"
    assert not E.is_physical(E.SENSORS) and not E.is_physical(E.sensor_path("stereo.left") + "/" + E.SENSOR_IMAGE)


def test_blueprint_gives_each_camera_a_2d_view():
    import rerun.blueprint as rrb

    from snakesim.components.viz.blueprint import default_blueprint

    bp = default_blueprint(np.zeros((1, 3)), [], [PINHOLE.lstrip("/")])
    views, todo = [], [bp.root_container]
    while todo:
        item = todo.pop()
        todo.extend(getattr(item, "contents", None) or [])
        views.append(item)
    cams = [v for v in views if isinstance(v, rrb.Spatial2DView)]
    assert [(c.origin, c.name) for c in cams] == [(PINHOLE.lstrip("/"), "cam/frame")]
