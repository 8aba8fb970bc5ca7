"""--ros2-mcap with perception sensors: the lidar's PointCloud2 and the stereo pair's Image, depth and
CameraInfo go into the same MCAP file as the robot's topics, logged at the sensors' sample times, and
decode (mcap-ros2-support) to what the sensors measured."""

import math

import numpy as np
import pytest

import test_mcap
import test_sensor_bridge as bridge_test
from snakesim.framework.assembly import resolve
from snakesim.framework.registry import default_registry
from snakesim.framework.session import Session

pytest.importorskip("mcap")
pytest.importorskip("mcap_ros2")


def test_sensor_topics_share_the_bag_with_the_robot_topics(dds_domain, tmp_path):
    from snakesim.components.ros2.attach import attach_ros2
    from snakesim.components.ros2.mcap_recorder import attach_mcap

    lidar_rate, camera_rate, duration = 10.0, 5.0, 0.6
    scene = tmp_path / "sensors.yaml"
    scene.write_text(bridge_test.SCENE % {"duration": duration, "lidar": lidar_rate, "camera": camera_rate})
    reg = default_registry()
    resolved = resolve(str(scene), search_path=reg.assembly_paths())
    attach_ros2(resolved, reg, params={"domain_id": dds_domain()})
    rec = attach_mcap(resolved, str(tmp_path / "run.mcap"))
    s = Session(resolved, reg)
    s.run()
    sensor_rec = next(n for n, c in s.plan.components.items() if c.type_name == "ros2_sensor_mcap")
    for name in (rec, sensor_rec):                      # either order: the last one finishes the file
        s.plan.caches[name].close()
    got = test_mcap._read(tmp_path / "run.mcap")
    # the robot's topics are still there, and the sensors' in the same file
    assert {"/clock", "/joint_states", "/tf", "/robot_description"} <= set(got)
    want = {"/lidar/points": ("sensor_msgs/msg/PointCloud2", lidar_rate),
            "/stereo/left/image_raw": ("sensor_msgs/msg/Image", camera_rate),
            "/stereo/left/depth": ("sensor_msgs/msg/Image", camera_rate),
            "/stereo/left/labels": ("sensor_msgs/msg/Image", camera_rate),
            "/stereo/left/camera_info": ("sensor_msgs/msg/CameraInfo", camera_rate),
            "/stereo/right/image_raw": ("sensor_msgs/msg/Image", camera_rate)}
    for topic, (typ, rate) in want.items():
        msgs = got[topic]
        assert {m[0] for m in msgs} == {typ}
        # logged at the samples' own times: 0, 1/rate, ... (the last tick at the end runs no update)
        times = sorted(m[3] for m in msgs)
        expect = [round(k / rate * 1e9) for k in range(int(math.floor(duration * rate + 1e-9)))]
        assert times == expect, (topic, times, expect)
        assert all(m[1].header.stamp.sec * 10**9 + m[1].header.stamp.nanosec == m[3] for m in msgs)
    cloud = got["/lidar/points"][0][1]
    assert (cloud.height, cloud.width, cloud.header.frame_id) == (8, 64, "lidar")
    xyz = np.frombuffer(bytes(cloud.data), dtype=np.float32).reshape(-1, 7)[:, :3]
    # the lidar frame is level 0.3 + 0.0675 m above the ice: the lowest return lies on it
    assert np.nanmin(xyz[:, 2]) == pytest.approx(-(0.3 + 0.0675), abs=1e-4)
    depth = got["/stereo/left/depth"][0][1]
    assert (depth.encoding, depth.width, depth.height) == ("32FC1", 64, 48)
    labels = got["/stereo/left/labels"][0][1]
    assert (labels.encoding, labels.width, labels.height) == ("mono16", 64, 48)
    # the ice (material 0 of flat-ice: label 1) fills the lower half of a level camera's view
    assert np.frombuffer(bytes(labels.data), "<u2").reshape(48, 64)[-1].tolist() == [1] * 64
    # the sensor frames in the one tf tree with the robot's links, each with one parent: the lidar is the URDF's
    # lidar link, each camera's optical frame hangs off the URDF's camera link (components/ros2/sensor_frames.py)
    parents = {}
    for topic in ("/tf", "/tf_static"):
        for _s, m, _r, _t in got.get(topic, []):
            for tr in m.transforms:
                parents.setdefault(tr.child_frame_id, set()).add(tr.header.frame_id)
    assert parents["camera_left_optical_frame"] == {"camera_left"}
    assert parents["camera_right_optical_frame"] == {"camera_right"}
    assert "lidar" in parents and "tail" in parents
    assert all(len(p) == 1 for p in parents.values()), {f: p for f, p in parents.items() if len(p) > 1}
