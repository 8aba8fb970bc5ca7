"""Camera projection models (issue 12): hand-derived projections, exact reductions between the
models, project/unproject round trips over whole images, CameraInfo, and the spec errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.components.perception.camera_models import (
    PAPER_FIGURE_7,
    PAPER_FIGURE_7_SIZE,
    PAPER_FIGURE_7_WORLD,
    CahvModel,
    CahvoreModel,
    CahvorModel,
    FisheyeModel,
    PinholeModel,
    camera_model_from_spec,
)

ROUND_TRIP = 1e-9  # pixels and unit-vector components, as issue 12 asks
W7, H7 = PAPER_FIGURE_7_SIZE


def tilted(x, y):
    return tuple(np.array([x, y, 1.0]) / math.hypot(x, y, 1.0))


# A wide CAHVORE with every term at work: C off the origin, O tilted from A, R, E, and the linearity.
def wide_cahvore(linearity):
    return {
        "kind": "cahvore", "c": (0.1, -0.2, 0.05), "a": (0.0, 0.0, 1.0),
        "h": (100.0, 0.0, 199.5), "v": (0.0, 100.0, 149.5), "o": tilted(0.02, -0.01),
        "r": (0.02, -0.01, 0.001), "e": (0.01, 0.005, -0.001), "linearity": linearity,
    }  # fmt: skip


MODELS = {  # name: (spec, width, height)
    "pinhole_fov": ({"kind": "pinhole", "fov": 90}, 64, 48),
    "pinhole_k": ({"kind": "pinhole", "fx": 120.0, "fy": 90.0, "cx": 20.0, "cy": 30.0}, 64, 48),
    "fisheye_200": ({"kind": "fisheye", "fov": 200}, 80, 60),
    "fisheye_360": ({"kind": "fisheye", "fov": 360}, 80, 60),  # corners past θ = π have no ray
    "cahv_fig7": (PAPER_FIGURE_7["cahv"], W7, H7),
    "cahvor_fig7": (PAPER_FIGURE_7["cahvor"], W7, H7),
    "cahvore_fig7": (PAPER_FIGURE_7["cahvore"], W7, H7),
    "cahv_fig7_world": (PAPER_FIGURE_7_WORLD["cahv"], W7, H7),
    "cahvor_fig7_world": (PAPER_FIGURE_7_WORLD["cahvor"], W7, H7),
    "cahvore_fig7_world": (PAPER_FIGURE_7_WORLD["cahvore"], W7, H7),
    "cahvore_fisheye": (wide_cahvore(0.0), 400, 300),  # 230° across
    "cahvore_half": (wide_cahvore(0.5), 400, 300),
    "cahvore_perspective": (wide_cahvore(1.0), 400, 300),
}


def build(name):
    spec, width, height = MODELS[name]
    return camera_model_from_spec(spec, width, height, where=name)


def pixel_grid(model):
    v, u = np.mgrid[0 : model.height, 0 : model.width]
    return np.stack([u.ravel(), v.ravel()], axis=1).astype(float)


# --- hand-derived projections -------------------------------------------------------------------


def test_pinhole_projects_and_unprojects_a_known_point():
    camera = PinholeModel(100, 100, fx=100.0, fy=100.0, cx=50.0, cy=50.0)
    uv, valid = camera.project([[1.0, 2.0, 10.0], [1.0, 2.0, -10.0], [1.0, 2.0, 0.0]])
    np.testing.assert_allclose(uv[0], [60.0, 70.0], rtol=0, atol=1e-12)  # 100·1/10 + 50, 100·2/10 + 50
    assert valid.tolist() == [True, False, False]
    assert np.isnan(uv[1:]).all()
    origins, directions = camera.unproject([[60.0, 70.0]])
    np.testing.assert_array_equal(origins, [[0.0, 0.0, 0.0]])
    np.testing.assert_allclose(directions[0], np.array([1.0, 2.0, 10.0]) / math.sqrt(105), rtol=0, atol=1e-15)


def test_pinhole_from_fov_is_centred_with_square_pixels():
    camera = camera_model_from_spec({"kind": "pinhole", "fov": 90}, 640, 480)
    assert (camera.fx, camera.fy, camera.cx, camera.cy) == pytest.approx((320.0, 320.0, 319.5, 239.5), abs=1e-12)
    assert camera.horizontal_fov == pytest.approx(math.pi / 2, abs=1e-12)
    assert camera.vertical_fov == pytest.approx(2 * math.atan(240 / 320), abs=1e-12)


@pytest.mark.parametrize("theta_deg", [0.0, 10.0, 45.0, 90.0, 120.0, 170.0, 179.9])
def test_fisheye_radius_is_f_theta_beyond_90_degrees(theta_deg):
    camera = FisheyeModel(400, 300, f=100.0, cx=199.5, cy=149.5)
    theta = math.radians(theta_deg)
    azimuths = np.radians([0.0, 30.0, 135.0, 250.0])
    directions = np.stack(
        [math.sin(theta) * np.cos(azimuths), math.sin(theta) * np.sin(azimuths), np.full(4, math.cos(theta))], axis=1
    )
    uv, valid = camera.project(3.0 * directions)
    assert valid.all()
    expected = np.stack([199.5 + 100 * theta * np.cos(azimuths), 149.5 + 100 * theta * np.sin(azimuths)], axis=1)
    np.testing.assert_allclose(uv, expected, rtol=0, atol=1e-10)


def test_fisheye_has_no_pixel_straight_behind_and_no_ray_past_the_antipode():
    camera = FisheyeModel(400, 300, f=50.0, cx=199.5, cy=149.5)
    _, valid = camera.project([[0.0, 0.0, -1.0], [0.0, 0.0, 0.0], [1e-9, 0.0, -1.0]])
    assert valid.tolist() == [False, False, True]
    _, directions = camera.unproject([[199.5 + 50 * math.pi * 1.01, 149.5]])
    assert np.isnan(directions).all()


def test_fisheye_fov_beyond_180():
    camera = camera_model_from_spec({"kind": "fisheye", "fov": 220}, 300, 200)
    assert camera.horizontal_fov == pytest.approx(math.radians(220), abs=1e-12)
    assert camera.vertical_fov == pytest.approx(math.radians(220) * 200 / 300, abs=1e-12)


def test_cahv_projects_a_known_point():
    # Figure 7's CAHV in its world frame: looking down from z = 35; a ground point 3.5 m along +x
    # and 7 m along −y is at depth 35, so x = (3.5·734.264 + 35·310)/35 and y = (7·714.264 + 35·320)/35.
    camera = camera_model_from_spec(PAPER_FIGURE_7_WORLD["cahv"], W7, H7)
    uv, valid = camera.project([[3.5, -7.0, 0.0], [0.0, 0.0, 40.0]])
    np.testing.assert_allclose(uv[0], [310 + 73.4264, 320 + 142.8528], rtol=0, atol=1e-10)
    assert valid.tolist() == [True, False]  # the second point is above (behind) the camera


def test_cahv_fields_of_view_are_the_edge_angles():
    camera = camera_model_from_spec(PAPER_FIGURE_7["cahv"], W7, H7)
    horizontal = math.atan(310.5 / 734.264) + math.atan(309.5 / 734.264)  # edges at u = −0.5, 619.5
    vertical = math.atan(320.5 / 714.264) + math.atan(319.5 / 714.264)
    assert camera.horizontal_fov == pytest.approx(horizontal, abs=1e-12)
    assert camera.vertical_fov == pytest.approx(vertical, abs=1e-12)


# --- round trips over whole images --------------------------------------------------------------


@pytest.mark.parametrize("name", MODELS)
def test_every_pixel_round_trips_through_its_ray(name):
    camera = build(name)
    origins, directions = camera.pixel_rays()
    assert origins.shape == directions.shape == (camera.height, camera.width, 3)
    origins, directions = origins.reshape(-1, 3), directions.reshape(-1, 3)
    grid = pixel_grid(camera)
    has_ray = ~np.isnan(directions).any(axis=1)
    if name == "fisheye_360":  # exactly the pixels farther than f·π from the centre lack a ray
        np.testing.assert_array_equal(~has_ray, np.hypot(*(grid - [camera.cx, camera.cy]).T) > camera.f * math.pi)
    else:
        assert has_ray.all()
    np.testing.assert_allclose(np.linalg.norm(directions[has_ray], axis=1), 1.0, rtol=0, atol=1e-15)
    for depth in (0.5, 5.0, 1e3):
        uv, valid = camera.project(origins[has_ray] + depth * directions[has_ray])
        assert valid.all()
        np.testing.assert_allclose(uv, grid[has_ray], rtol=0, atol=ROUND_TRIP)


@pytest.mark.parametrize("name", MODELS)
def test_points_round_trip_through_their_pixels(name):
    camera = build(name)
    rng = np.random.default_rng(12)
    centre, _ = camera.unproject([[(camera.width - 1) / 2, (camera.height - 1) / 2]])
    spread = math.tan(min(max(camera.horizontal_fov, camera.vertical_fov) / 2, 1.3))  # about the image's
    lateral = rng.normal(size=(20000, 3))
    directions = camera.axis + spread * (lateral - np.outer(lateral @ camera.axis, camera.axis))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    points = centre[0] + rng.uniform(0.5, 100.0, size=(20000, 1)) * directions
    uv, valid = camera.project(points)
    seen = valid & camera.in_image(uv)
    assert seen.sum() > 1000
    origins, rays = camera.unproject(uv[seen])
    expected = points[seen] - origins
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    np.testing.assert_allclose(rays, expected, rtol=0, atol=ROUND_TRIP)


# --- reductions between the models --------------------------------------------------------------


def random_points_in_front(model, n=5000, seed=7):
    rng = np.random.default_rng(seed)
    _, directions = model.unproject(rng.uniform(-50, [model.width + 50, model.height + 50], size=(n, 2)))
    origins, _ = model.unproject([[0.0, 0.0]])
    return origins[0] + rng.uniform(0.5, 200, size=(n, 1)) * directions


def with_keys(spec, **changes):
    return {**spec, **changes}


@pytest.mark.parametrize("frame", [PAPER_FIGURE_7, PAPER_FIGURE_7_WORLD])
def test_cahvor_with_zero_r_is_cahv_exactly(frame):
    cahv = camera_model_from_spec(frame["cahv"], W7, H7)
    cahvor = camera_model_from_spec(with_keys(frame["cahvor"], r=(0.0, 0.0, 0.0)), W7, H7)
    points = random_points_in_front(cahv)
    uv_cahv, valid_cahv = cahv.project(points)
    uv_cahvor, valid_cahvor = cahvor.project(points)
    np.testing.assert_array_equal(uv_cahvor, uv_cahv)  # bitwise: μ = 0 leaves P − C untouched
    np.testing.assert_array_equal(valid_cahvor, valid_cahv)
    uv = pixel_grid(cahv)[::97]
    for got, want in zip(cahvor.unproject(uv), cahv.unproject(uv)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_cahvore_with_zero_r_e_and_linearity_1_is_cahv():
    cahv = camera_model_from_spec(PAPER_FIGURE_7_WORLD["cahv"], W7, H7)
    spec = with_keys(PAPER_FIGURE_7_WORLD["cahvore"], r=(0.0, 0.0, 0.0), e=(0.0, 0.0, 0.0), linearity=1.0)
    cahvore = camera_model_from_spec(spec, W7, H7)
    points = random_points_in_front(cahv)
    uv_cahv, valid = cahv.project(points)
    uv_cahvore, valid_cahvore = cahvore.project(points)
    np.testing.assert_array_equal(valid_cahvore, valid)
    np.testing.assert_allclose(uv_cahvore, uv_cahv, rtol=0, atol=ROUND_TRIP)
    uv = pixel_grid(cahv)[::97]
    for got, want in zip(cahvore.unproject(uv), cahv.unproject(uv)):
        np.testing.assert_allclose(got, want, rtol=0, atol=ROUND_TRIP)


def test_cahv_of_a_pinhole_is_that_pinhole():
    pinhole = PinholeModel(64, 48, fx=120.0, fy=90.0, cx=20.0, cy=30.0)
    cahv = CahvModel.from_pinhole(pinhole)
    points = random_points_in_front(pinhole)
    for got, want in zip(cahv.project(points), pinhole.project(points)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    uv = pixel_grid(pinhole)
    for got, want in zip(cahv.unproject(uv), pinhole.unproject(uv)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
    assert cahv.camera_info() == pinhole.camera_info()


def test_cahvore_with_linearity_0_is_the_equidistant_fisheye():
    fisheye = FisheyeModel(400, 300, f=100.0, cx=199.5, cy=149.5)
    cahvore = CahvoreModel(
        400, 300, c=(0.0, 0.0, 0.0), a=(0.0, 0.0, 1.0), h=(100.0, 0.0, 199.5), v=(0.0, 100.0, 149.5),
        o=(0.0, 0.0, 1.0), r=(0.0, 0.0, 0.0), e=(0.0, 0.0, 0.0), linearity=0.0,
    )  # fmt: skip
    rng = np.random.default_rng(3)
    points = rng.normal(size=(5000, 3))  # all around, 120° and more from the axis included
    uv_fisheye, valid = fisheye.project(points)
    uv_cahvore, valid_cahvore = cahvore.project(points)
    np.testing.assert_array_equal(valid_cahvore, valid)
    np.testing.assert_allclose(uv_cahvore, uv_fisheye, rtol=0, atol=ROUND_TRIP)


def test_figure_7_world_and_sensor_constants_are_the_same_cameras():
    world_from_sensor = np.diag([1.0, -1.0, -1.0])  # 180° about x; the camera at (0, 0, 35)
    camera_position = np.array([0.0, 0.0, 35.0])
    for kind in ("cahv", "cahvor", "cahvore"):
        world = camera_model_from_spec(PAPER_FIGURE_7_WORLD[kind], W7, H7)
        sensor = camera_model_from_spec(PAPER_FIGURE_7[kind], W7, H7)
        points = random_points_in_front(world)
        uv_world, valid = world.project(points)
        uv_sensor, valid_sensor = sensor.project((points - camera_position) @ world_from_sensor)
        np.testing.assert_array_equal(valid_sensor, valid)
        np.testing.assert_allclose(uv_sensor, uv_world, rtol=0, atol=ROUND_TRIP)


# --- distortion ---------------------------------------------------------------------------------


def angle_from(axis, directions):
    return np.arccos(np.clip(directions @ axis, -1, 1))


def test_figure_7_cahvor_bends_rays_as_r_predicts():
    cahv = camera_model_from_spec(PAPER_FIGURE_7["cahv"], W7, H7)
    cahvor = camera_model_from_spec(PAPER_FIGURE_7["cahvor"], W7, H7)
    r0, r1, r2 = PAPER_FIGURE_7["cahvor"]["r"]
    # Image corners, and the middles of the left and top edges (nearer the axis).
    uv = [[-0.5, -0.5], [W7 - 0.5, -0.5], [W7 - 0.5, H7 - 0.5], [-0.5, H7 - 0.5], [-0.5, 319.5], [309.5, -0.5]]
    axis = cahvor.axis
    seen = angle_from(axis, cahv.unproject(uv)[1])  # the distorted angle: tan = χ'
    true = angle_from(axis, cahvor.unproject(uv)[1])  # the scene's angle: tan = χ = √τ
    tau = np.tan(true) ** 2
    mu = r0 + r1 * tau + r2 * tau**2
    np.testing.assert_allclose((1 + mu) * np.tan(true), np.tan(seen), rtol=1e-12, atol=0)
    # With R = (0.05, −0.21, 0.01), μ < 0 for 0.241 < τ < 20.8: at the corners (τ ≈ 0.41) it is barrel, they
    # see a wider angle than CAHV's; μ > 0 at the edge middles (τ ≈ 0.17, 0.20): they see a narrower one.
    assert (mu[:4] < 0).all() and (true[:4] > seen[:4]).all()
    assert (mu[4:] > 0).all() and (true[4:] < seen[4:]).all()


def test_points_past_the_distortion_fold_are_invalid_and_so_are_their_pixels():
    # r1 = −0.3: χ' = χ − 0.3 χ³ rises until χ² = 1/0.9 and folds back beyond.
    camera = CahvorModel(
        400, 300, c=(0.0, 0.0, 0.0), a=(0.0, 0.0, 1.0), h=(100.0, 0.0, 199.5), v=(0.0, 100.0, 149.5),
        o=(0.0, 0.0, 1.0), r=(0.0, -0.3, 0.0),
    )  # fmt: skip
    fold = math.sqrt(1 / 0.9)
    _, valid = camera.project([[fold * 0.99, 0.0, 1.0], [fold * 1.01, 0.0, 1.0]])
    assert valid.tolist() == [True, False]
    fold_image = fold - 0.3 * fold**3
    u_fold = 199.5 + 100 * fold_image
    _, directions = camera.unproject([[u_fold - 0.01, 149.5], [u_fold + 0.01, 149.5]])
    assert not np.isnan(directions[0]).any() and np.isnan(directions[1]).all()


def test_cahvore_rays_start_at_the_moving_entrance_point():
    spec = wide_cahvore(0.0)
    camera = camera_model_from_spec(spec, 400, 300)
    origins, directions = camera.unproject([[-0.5, -0.5], [199.5, 149.5]])
    o, c = np.array(spec["o"]), np.array(spec["c"])
    theta = angle_from(o, directions)
    e0, e1, e2 = spec["e"]
    shift = (theta / np.sin(theta) - 1) * (e0 + e1 * theta**2 + e2 * theta**4)  # Gennery's δ(θ)
    np.testing.assert_allclose(origins[0], c + shift[0] * o, rtol=0, atol=1e-15)
    assert abs(shift[0]) > 1e-3  # the corner is ~140° off axis: the pupil has moved
    np.testing.assert_allclose(origins[1], c + shift[1] * o, rtol=0, atol=1e-15)
    for name in ("pinhole_k", "fisheye_200", "cahvor_fig7_world"):  # central models: the centre
        central = build(name)
        origins, _ = central.unproject(pixel_grid(central)[::37])
        np.testing.assert_array_equal(origins, np.broadcast_to(origins[0], origins.shape))


# --- frustum, image bounds ----------------------------------------------------------------------


def test_corner_rays_and_in_image():
    camera = PinholeModel(64, 48, fx=120.0, fy=90.0, cx=20.0, cy=30.0)
    _, corners = camera.corner_rays()
    outer = [(-0.5, -0.5), (63.5, -0.5), (63.5, 47.5), (-0.5, 47.5)]
    expected = np.array([[(u - 20.0) / 120.0, (v - 30.0) / 90.0, 1.0] for u, v in outer])
    np.testing.assert_allclose(corners, expected / np.linalg.norm(expected, axis=1, keepdims=True), atol=1e-15)
    inside = camera.in_image([[-0.5, -0.5], [63.49, 47.49], [63.5, 0.0], [0.0, -0.51], [np.nan, 0.0]])
    assert inside.tolist() == [True, True, False, False, False]


# --- CameraInfo ---------------------------------------------------------------------------------


def test_pinhole_camera_info_k_reproduces_project_and_p_is_k_with_zero_translation():
    camera = PinholeModel(64, 48, fx=120.0, fy=90.0, cx=20.0, cy=30.0)
    info = camera.camera_info()
    assert info["distortion_model"] == "plumb_bob" and info["d"] == [0.0] * 5
    k, p, r = np.reshape(info["k"], (3, 3)), np.reshape(info["p"], (3, 4)), np.reshape(info["r"], (3, 3))
    points = random_points_in_front(camera)
    homogeneous = points @ k.T
    uv, _ = camera.project(points)
    np.testing.assert_allclose(homogeneous[:, :2] / homogeneous[:, 2:], uv, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(p, np.hstack([k, np.zeros((3, 1))]))
    np.testing.assert_array_equal(r, np.eye(3))


def test_camera_info_of_the_other_models():
    fisheye = FisheyeModel(400, 300, f=100.0, cx=199.5, cy=149.5).camera_info()
    assert fisheye["distortion_model"] == "equidistant" and fisheye["d"] == [0.0] * 4
    assert fisheye["k"] == [100.0, 0.0, 199.5, 0.0, 100.0, 149.5, 0.0, 0.0, 1.0]
    cahv = camera_model_from_spec(PAPER_FIGURE_7["cahv"], W7, H7).camera_info()  # C = 0, A = z: a pinhole
    assert cahv["k"] == [734.264, 0.0, 310.0, 0.0, 714.264, 320.0, 0.0, 0.0, 1.0]
    assert camera_model_from_spec(PAPER_FIGURE_7_WORLD["cahv"], W7, H7).camera_info() is None  # C ≠ 0
    skewed = with_keys(PAPER_FIGURE_7["cahv"], h=(734.264, 5.0, 310.0))
    assert camera_model_from_spec(skewed, W7, H7).camera_info() is None  # H' not orthogonal to V'
    for kind in ("cahvor", "cahvore"):
        assert camera_model_from_spec(PAPER_FIGURE_7[kind], W7, H7).camera_info() is None


# --- bad input: one case per class, each message names where, the key and the value --------------

GOOD = PAPER_FIGURE_7["cahvore"]
BAD = {  # case: (spec, width, height, words the message must hold)
    "unknown kind": ({"kind": "pinhol"}, 64, 48, ["kind = 'pinhol'", "pinhole, fisheye, cahv, cahvor, cahvore"]),
    "missing kind": ({"fov": 90}, 64, 48, ["kind", "missing", "pinhole, fisheye"]),
    "not a mapping": ("pinhole", 64, 48, ["'pinhole'", "mapping"]),
    "pinhole fov 180": ({"kind": "pinhole", "fov": 180}, 64, 48, ["fov = 180", "(0, 180)", "fisheye"]),
    "pinhole fov 0": ({"kind": "pinhole", "fov": 0}, 64, 48, ["fov = 0", "(0, 180)"]),
    "fisheye fov negative": ({"kind": "fisheye", "fov": -10}, 64, 48, ["fov = -10", "(0, 360]"]),
    "fisheye fov past 360": ({"kind": "fisheye", "fov": 400}, 64, 48, ["fov = 400", "(0, 360]"]),
    "NaN": ({"kind": "pinhole", "fov": math.nan}, 64, 48, ["fov = nan", "finite"]),
    "inf in a vector": (with_keys(GOOD, c=(0.0, math.inf, 0.0)), W7, H7, ["c[1] = inf", "finite"]),
    "vector of 2": (with_keys(GOOD, c=(0.0, 0.0)), W7, H7, ["c = (0.0, 0.0)", "3 finite numbers"]),
    "focal length not positive": ({"kind": "pinhole", "fx": -1, "fy": 1, "cx": 0, "cy": 0}, 64, 48, ["fx = -1", "> 0"]),
    "both pinhole forms": ({"kind": "pinhole", "fov": 90, "fx": 3}, 64, 48, ["fov", "fx", "not both"]),
    "incomplete pinhole": ({"kind": "pinhole", "fx": 3}, 64, 48, ["missing fy, cx, cy"]),
    "unknown key": ({"kind": "pinhole", "fov": 90, "focal": 3}, 64, 48, ["focal = 3", "keys: fov, fx, fy, cx, cy"]),
    "missing key": ({k: v for k, v in GOOD.items() if k != "e"}, W7, H7, ["e: missing", "cahvore"]),
    "width zero": ({"kind": "pinhole", "fov": 90}, 0, 48, ["width = 0", "positive integer"]),
    "height negative": ({"kind": "pinhole", "fov": 90}, 64, -2, ["height = -2", "positive integer"]),
    "A not unit": (with_keys(GOOD, a=(0.0, 0.0, 2.0)), W7, H7, ["a = (0.0, 0.0, 2.0)", "|A| = 2", "within 1e-06 of 1"]),
    "H parallel to A": (with_keys(GOOD, h=(0.0, 0.0, 5.0)), W7, H7, ["h = (0.0, 0.0, 5.0)", "parallel to A"]),
    "V parallel to A": (with_keys(GOOD, v=(0.0, 0.0, 5.0)), W7, H7, ["v = (0.0, 0.0, 5.0)", "parallel to A"]),
    "mirrored image": (with_keys(GOOD, v=(0, -714.264, 320)), W7, H7, ["v = (0.0, -714.264, 320.0)", "(H × V)·A"]),
    "H parallel to V": (with_keys(GOOD, v=(700.0, 0.0, 320.0)), W7, H7, ["v = (700.0, 0.0, 320.0)", "(H × V)·A = 0"]),
    "O not unit": (with_keys(GOOD, o=(0.0, 0.0, 0.9)), W7, H7, ["o = (0.0, 0.0, 0.9)", "|O| = 0.9"]),
    "O not toward A": (with_keys(GOOD, o=(0.0, 1.0, 0.0)), W7, H7, ["o = (0.0, 1.0, 0.0)", "O·A = 0", "> 0"]),
    "R folds the axis": (with_keys(GOOD, r=(-1.0, 0.0, 0.0)), W7, H7, ["r = (-1.0, 0.0, 0.0)", "1 + r0", "> 0"]),
    "linearity above 1": (with_keys(GOOD, linearity=1.5), W7, H7, ["linearity = 1.5", "[0, 1]"]),
    "linearity below 0": (with_keys(GOOD, linearity=-0.1), W7, H7, ["linearity = -0.1", "[0, 1]"]),
}


@pytest.mark.parametrize("case", BAD)
def test_bad_specs_are_refused_with_where_key_and_value(case):
    spec, width, height, words = BAD[case]
    with pytest.raises(ValueError) as raised:
        camera_model_from_spec(spec, width, height, where="scene.yaml: front_camera.model")
    message = str(raised.value)
    assert message.startswith("scene.yaml: front_camera.model: ")
    for word in words:
        assert word in message, message


def test_direct_construction_checks_the_same_geometry():
    with pytest.raises(ValueError, match=r"a = \(0, 0, 1.1\): \|A\| = 1.1, must be within 1e-06 of 1"):
        CahvModel(10, 10, c=(0, 0, 0), a=(0, 0, 1.1), h=(1, 0, 5), v=(0, 1, 5))
    with pytest.raises(ValueError, match="width = 0"):
        PinholeModel(0, 10, 1.0, 1.0, 0.0, 0.0)
