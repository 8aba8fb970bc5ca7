"""`snakesim run --ros2` with perception sensors, seen from a separate process: a lidar's PointCloud2 and a
stereo pair's Image, depth and CameraInfo on their topics, stamped at the sensors' rates, decoded with
rosbags' standard definitions; the bytes the bridge writes decode to what the sensor measured."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from ros2_peer import run_beside

HERE = Path(__file__).parent
LIDAR_RATE, CAMERA_RATE, DURATION = 10.0, 5.0, 0.6
SCENE = """\
description: EELS 1.0 (2 modules, head) held 0.3 m above flat ice in zero gravity, head sensors on
sim: {duration: %(duration)s, dt: 0.002, integrator: rk4}
components:
  ground: {type: terrain, params: {name: flat-ice}}
  robot: {type: multibody, params: {design: eels-1.0, modules: 2, head: true, gravity: [0, 0, 0],
                                    base_position: [0, 0, 0.3]}}
  sensors: {type: sensor_scene, params: {extent: 10}}
  lidar: {type: lidar, rate: %(lidar)s, params: {beams: {kind: grid, channels: 8, horizontal_samples: 64,
                                                           vertical_fov: [-40, 10]}}}
  stereo: {type: stereo_camera, rate: %(camera)s, params: {width: 64, height: 48, model: {kind: pinhole, fov: 90}}}
connections:
  - ground.terrain -> sensors.terrain
  - robot.link_poses -> sensors.link_poses
  - sensors.world -> lidar.world, stereo.world
"""


@pytest.mark.slow
def test_point_clouds_images_and_camera_info_reach_a_separate_process(dds_domain, tmp_path):
    domain = dds_domain()
    scene = tmp_path / "sensors.yaml"
    scene.write_text(SCENE % {"duration": DURATION, "lidar": LIDAR_RATE, "camera": CAMERA_RATE})
    got, _ = run_beside(("sensor_subscriber.py", domain, 60, "/lidar", "/stereo/left"),
                        [scene, "--ros2-domain", domain, "--quiet"], timeout=120, peer_timeout=60)
    # every sample of the run, at the sensors' own sample times (t = 0, 1/rate, ...; the last tick runs no update)
    expected = {"points": LIDAR_RATE, "image": CAMERA_RATE, "depth": CAMERA_RATE, "info": CAMERA_RATE}
    for key, rate in expected.items():
        stamps = sorted(r["t"] for r in got[key])
        want = [k / rate for k in range(int(math.floor(DURATION * rate + 1e-9)))]
        assert np.allclose(stamps, want, atol=1e-6), (key, stamps, want)
    cloud = got["points"][0]
    assert (cloud["height"], cloud["width"]) == (8, 64) and cloud["frame"] == "lidar"
    assert cloud["fields"] == ["x", "y", "z", "intensity", "ring", "status", "t", "label"]
    assert cloud["returns"] > 0 and cloud["finite_returns"] and cloud["nan_misses"]
    # the lidar frame is level 0.3 + 0.0675 m above the ice: the lowest return lies on it
    assert abs(cloud["min_z"] + 0.3 + 0.0675) < 1e-4
    img = got["image"][0]
    assert (img["width"], img["height"], img["encoding"], img["step"], img["bytes"]) == (64, 48, "mono8", 64, 64 * 48)
    assert got["depth"][0]["encoding"] == "32FC1" and got["depth"][0]["bytes"] == 4 * 64 * 48
    info = got["info"][0]
    f = 32.0 / math.tan(math.radians(45.0))                      # 90° across 64 px
    np.testing.assert_allclose(info["k"], [f, 0, 31.5, 0, f, 23.5, 0, 0, 1], atol=1e-9)
    # the URDF's camera_left link is where the left camera sits: its optical frame (tf tree: test_frames_and_camera_info)
    assert info["model"] == "plumb_bob" and img["frame"] == info["frame"] == "camera_left_optical_frame"


def test_bridge_bytes_decode_to_the_measurement():
    """Each message the bridge writes decodes with rosbags' standard definition to the sample's values."""
    sys.path.insert(0, str(HERE.parent / "perception"))
    from scenes import USES, all_links_at, terrain, world_at

    from snakesim.components.perception import Camera, Lidar
    from snakesim.components.ros2 import sensor_messages as SM
    from snakesim.components.ros2.messages import typestore
    from snakesim.framework import Harness

    ts = typestore()
    world = world_at(terrain({"kind": "plane"}), all_links_at((0.0, 0.0, 1.0)))
    h = Harness(Lidar, {"link": "lidar", "preset": "solid-state-rosette", "min_range": 0.1}, rate=10.0, uses=USES)
    h.inputs.world = world
    scan = h.outputs()["scan"]
    m = ts.deserialize_cdr(SM.point_cloud2(ts, scan), SM.POINT_CLOUD2)
    assert (m.height, m.width, m.point_step, m.is_dense) == (1, len(scan.range), SM.POINT_STEP, False)
    raw = np.frombuffer(m.data.tobytes(), dtype=SM._CLOUD_DTYPE)
    np.testing.assert_array_equal(np.stack([raw["x"], raw["y"], raw["z"]], axis=1), scan.points)
    np.testing.assert_array_equal(raw["intensity"], scan.intensity)
    np.testing.assert_array_equal(raw["status"], scan.status)
    np.testing.assert_array_equal(raw["t"], scan.time)
    np.testing.assert_array_equal(raw["label"], scan.label)
    assert {f.name: (f.offset, f.datatype) for f in m.fields}["label"] == (24, SM.UINT16)
    c = Harness(Camera, {"link": "camera_left", "color": True, "width": 32, "height": 24}, rate=5.0, uses=USES)
    c.inputs.world = world
    frame = c.outputs()["frame"]
    im = ts.deserialize_cdr(SM.image(ts, frame), SM.IMAGE)
    pix = np.frombuffer(im.data.tobytes(), np.uint8).reshape(24, 32, 3)
    np.testing.assert_array_equal(pix, np.rint(np.clip(frame.image, 0, 1) * 255).astype(np.uint8))
    dm = ts.deserialize_cdr(SM.depth_image(ts, frame), SM.IMAGE)
    np.testing.assert_array_equal(np.frombuffer(dm.data.tobytes(), "<f4").reshape(24, 32), frame.depth)
    lm = ts.deserialize_cdr(SM.label_image(ts, frame), SM.IMAGE)
    assert (lm.encoding, lm.step, lm.height, lm.width) == ("mono16", 64, 24, 32)
    np.testing.assert_array_equal(np.frombuffer(lm.data.tobytes(), "<u2").reshape(24, 32), frame.label)
    assert (im.header.stamp.sec, im.header.stamp.nanosec) == (0, 0) and im.header.frame_id == "component"
