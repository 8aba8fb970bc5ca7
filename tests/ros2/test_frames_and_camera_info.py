"""What tf2, rviz2, Foxglove and stereo_image_proc need from `snakesim run --ros2` (issue 26, items 1-3 and the
IMU covariances), seen by an independent client (frames_subscriber.py: no snakesim import, rosbags' CDR codec):
every frame on /tf and /tf_static has exactly one parent and reaches `world`; the sensor messages' frame_ids
are in that tree (the stereo pair on the URDF's camera_left/camera_right); /robot_description names its
meshes by file:// URIs of files that exist; the right CameraInfo's P[3] = -fx·B; the IMU's covariance
diagonals are its noise variances."""

import math
import re
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np
import pytest

from ros2_peer import run_beside

GYRO, ACCEL = 0.003, 0.04          # rad/s, m/s²: the IMU's noise (standard deviations per axis)
WIDTH, HEIGHT = 160, 120
SCENE = """\
description: EELS 1.0 (2 modules, head) held 0.3 m above flat ice in zero gravity, head sensors and an IMU on
sim: {duration: 0.3, dt: 0.002, integrator: rk4}
components:
  ground: {type: terrain, params: {name: flat-ice}}
  robot: {type: multibody, params: {design: eels-1.0, modules: 2, head: true, gravity: [0, 0, 0],
                                    base_position: [0, 0, 0.3]}}
  imu: {type: imu, rate: 100, params: {link: imu, gyro_noise: %(gyro)r, accel_noise: %(accel)r, seed: 3}}
  sensors: {type: sensor_scene, params: {extent: 10}}
  lidar: {type: lidar, rate: 10, params: {beams: {kind: grid, channels: 4, horizontal_samples: 32,
                                                    vertical_fov: [-40, 10]}}}
  stereo: {type: stereo_camera, rate: 10, params: {width: %(w)d, height: %(h)d, model: {kind: pinhole, fov: 90}}}
connections:
  - ground.terrain -> sensors.terrain
  - robot.link_poses -> sensors.link_poses, imu.link_poses
  - robot.link_rotations -> imu.link_rotations
  - robot.link_velocities -> imu.link_velocities
  - robot.link_accelerations -> imu.link_accelerations
  - sensors.world -> lidar.world, stereo.world
"""


@pytest.fixture(scope="module")
def seen(dds_domain, tmp_path_factory):
    domain = dds_domain()
    scene = tmp_path_factory.mktemp("frames") / "frames.yaml"
    scene.write_text(SCENE % {"gyro": GYRO, "accel": ACCEL, "w": WIDTH, "h": HEIGHT})
    got, _ = run_beside(("frames_subscriber.py", domain, 60), [scene, "--ros2-domain", domain, "--quiet"],
                        timeout=120, peer_timeout=60)
    return got


def _parents(seen) -> dict[str, set]:
    parents: dict[str, set] = {}
    for topic in ("tf", "tf_static"):
        for parent, child in seen["edges"][topic]:
            parents.setdefault(child, set()).add((topic, parent))
    return parents


def test_every_frame_has_one_parent_and_reaches_world(seen):
    parents = _parents(seen)
    assert parents, "no transforms received"
    twice = {child: sorted(p) for child, p in parents.items() if len(p) != 1}
    assert not twice, f"frames with more than one parent (or on both /tf and /tf_static): {twice}"
    parent = {child: next(iter(p))[1] for child, p in parents.items()}
    for frame in parent:
        seen_on_way, f = [], frame
        while f != "world":
            assert f in parent, f"{frame}: its chain {seen_on_way + [f]} stops before world"
            assert f not in seen_on_way, f"{frame}: cycle {seen_on_way + [f]}"
            seen_on_way.append(f)
            f = parent[f]
    # the sensors' frames are static, from the link they are mounted on (the URDF's links where they sit)
    static = {child: p for p, child in seen["edges"]["tf_static"]}
    assert static["camera_left_optical_frame"] == "camera_left"
    assert static["camera_right_optical_frame"] == "camera_right"
    assert static["lidar"] == "head" and static["camera_left"] == "head" and static["imu"] == "head"


def test_sensor_frame_ids_are_in_the_tree(seen):
    frames = set(_parents(seen)) | {"world"}
    ids = seen["frame_ids"]
    assert set(ids) == {"imu", "points", "left_image", "right_image", "left_info", "right_info"}, ids
    for key, got in ids.items():
        assert len(got) == 1 and got[0] in frames, (key, got)
    assert ids["points"] == ["lidar"] and ids["imu"] == ["imu"]
    assert ids["left_image"] == ids["left_info"] == ["camera_left_optical_frame"]
    assert ids["right_image"] == ids["right_info"] == ["camera_right_optical_frame"]


def test_right_camera_info_carries_the_baseline(seen):
    from snakesim.components.perception.camera import StereoCameraParams
    from snakesim.components.perception.camera_models import camera_model_from_spec

    model = camera_model_from_spec({"kind": "pinhole", "fov": 90.0}, WIDTH, HEIGHT)
    fx, B = model.fx, StereoCameraParams(link="camera_left").baseline
    assert fx * B == pytest.approx(5.4, abs=1e-9)                 # 80 px × 6.75 cm
    left, right = seen["info"]["left_info"], seen["info"]["right_info"]
    for info in (left, right):
        assert (info["width"], info["height"], info["model"]) == (WIDTH, HEIGHT, "plumb_bob")
        assert info["d"] == [0.0] * 5 and info["r"] == [1, 0, 0, 0, 1, 0, 0, 0, 1]   # rectified already
        K = np.reshape(info["k"], (3, 3))
        P = np.reshape(info["p"], (3, 4))
        np.testing.assert_allclose(P[:, :3], K, atol=1e-12)                          # P = [K | t]
        np.testing.assert_allclose(K, [[fx, 0, model.cx], [0, model.fy, model.cy], [0, 0, 1]], atol=1e-12)
    assert left["p"][3] == 0.0 and left["p"][7] == 0.0 and right["p"][7] == 0.0
    assert abs(right["p"][3] - (-fx * B)) <= 1e-9


def test_robot_description_meshes_are_file_uris_of_existing_files(seen):
    meshes = seen["meshes"]
    assert meshes, "no <mesh> in /robot_description"
    for uri in meshes:
        assert uri.startswith("file:///"), uri
        path = Path(unquote(urlparse(uri).path))
        assert path.is_absolute() and path.is_file(), uri


def test_imu_covariances_are_the_noise_variances(seen):
    from snakesim.components.ros2.publisher import EXACT_VARIANCE

    imu = seen["imu"]
    for key, sigma in (("angular_velocity_covariance", GYRO), ("linear_acceleration_covariance", ACCEL),
                       ("orientation_covariance", math.sqrt(EXACT_VARIANCE))):   # orientation: exact (no noise)
        cov = np.reshape(imu[key], (3, 3))
        np.testing.assert_allclose(np.diag(cov), [sigma ** 2] * 3, rtol=1e-12, err_msg=key)
        assert np.count_nonzero(cov - np.diag(np.diag(cov))) == 0, key


def test_covariances_of_quantities_not_provided_start_with_minus_one():
    from snakesim.components.ros2.publisher import imu_covariances

    cov = imu_covariances(0.0, 0.1, 0.2, provides=("angular_velocity", "linear_acceleration"))
    assert cov["orientation"] == [-1.0] + [0.0] * 8
    assert cov["angular_velocity"][::4] == pytest.approx([0.01] * 3) and cov["linear_acceleration"][0] == 0.2 ** 2


def test_package_uris_on_request(tmp_path):
    from snakesim.components.multibody.robot_model import RobotModel
    from snakesim.components.ros2.robot_description import ros_robot_description

    robot = RobotModel.load(design="eels-1.0", modules=2)
    text = ros_robot_description(robot, package="eels_description")
    uris = re.findall(r'<mesh\b[^>]*\bfilename="([^"]*)"', text)
    assert uris and all(u.startswith("package://eels_description/meshes/screw_") for u in uris)
    assert "../meshes/" in robot.urdf                                 # the robot's own URDF keeps its names
    with pytest.raises(ValueError, match="not under mesh_package_path"):
        ros_robot_description(robot, package="eels_description", package_path=tmp_path)
