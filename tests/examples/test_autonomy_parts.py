"""examples/autonomy's parts alone, without a sim: the cost map from points, the planner on it, the
follower's steering sense, the scan's deskew against a known motion, and the hand-read PointCloud2
against rosbags' CDR codec."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).resolve().parents[2] / "examples" / "autonomy"


def load(name: str):
    """An example module by file, under a name of its own (the example's modules import each other by
    their plain names, so its folder goes on sys.path while it loads)."""
    sys.path.insert(0, str(HERE))
    try:
        spec = importlib.util.spec_from_file_location(f"autonomy_example_{name}", HERE / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod
    finally:
        sys.path.remove(str(HERE))


cost_map, planner, follower, deskew = load("cost_map"), load("planner"), load("follower"), load("deskew")


def flat_ground(x0=0.0, x1=4.0, y0=-1.0, y1=1.0, step=0.02) -> np.ndarray:
    x, y = np.meshgrid(np.arange(x0, x1, step), np.arange(y0, y1, step))
    return np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])


def small_map(**kw):
    return cost_map.CostMap(cost_map.CostMapParams(**{"x0": 0.0, "x1": 4.0, "y0": -1.0, "y1": 1.0,
                                                      "resolution": 0.05, "min_hits": 1, **kw}))


def test_a_block_seen_by_its_points_is_an_obstacle_and_the_ground_is_not():
    m = small_map(inflate=0.2, soft=0.3)
    block = np.array([[x, y, 0.3] for x in np.arange(2.0, 2.2, 0.01) for y in np.arange(-0.1, 0.1, 0.01)])
    m.add(np.vstack([flat_ground(), block]))
    ob = m.obstacles()
    xy = m.center(*np.nonzero(ob))
    # the block's cells, and only they (its edge cells may include the slope to the ground next to it)
    assert ob.any()
    assert (xy[:, 0] > 2.0 - 0.06).all() and (xy[:, 0] < 2.2 + 0.06).all() and (np.abs(xy[:, 1]) < 0.16).all()
    cost = m.cost()
    i, j, _ = m.cell(np.array([[2.1, 0.25], [2.1, 0.45], [2.1, 0.8]]))
    # 0.15 m from the block's side: lethal (inflate 0.2); 0.35 m: soft (in 0.2..0.5); 0.7 m: plain ground
    assert np.isinf(cost[i[0], j[0]]) and 1.0 < cost[i[1], j[1]] < 1.0 + m.p.soft_weight
    assert cost[i[2], j[2]] == pytest.approx(1.0)


def test_a_tilted_view_of_flat_ground_is_not_an_obstacle():
    # a 0.02 rad pose error lifts the ground 12 cm at 6 m: above max_step globally, not locally
    m = small_map(x1=8.0)
    ground = flat_ground(0.0, 8.0)
    ground[:, 2] = 0.02 * ground[:, 0]
    m.add(ground)
    # and two scans of the same ground with different errors (0 and 0.02 rad) are not either
    m.add(flat_ground(0.0, 8.0))
    assert not m.obstacles().any()


def test_a_step_seen_in_fewer_than_min_hits_scans_is_not_yet_an_obstacle():
    m = small_map(min_hits=2)
    block = flat_ground(2.0, 2.2, -0.1, 0.1) + [0, 0, 0.3]
    scan = np.vstack([flat_ground(), block])
    m.add(scan)
    assert not m.obstacles().any()
    m.add(scan)
    assert m.obstacles().any()


def test_a_low_bump_under_the_step_threshold_is_free():
    m = small_map(max_step=0.05, max_slope=1.2)
    bump = flat_ground(1.0, 1.5, -0.2, 0.2) + [0, 0, 0.03]
    m.add(np.vstack([flat_ground(), bump]))
    assert not m.obstacles().any()


def wall_with_gap(m, gap_y: float):
    """Points of a 0.3 m wall across the map at x = 2 with a 0.6 m gap centred at gap_y."""
    ys = np.arange(-1.0, 1.0, 0.01)
    ys = ys[np.abs(ys - gap_y) > 0.3]
    wall = np.array([[x, y, 0.3] for x in (1.98, 2.0, 2.02) for y in ys])
    m.add(np.vstack([flat_ground(), wall]))


def test_the_planner_goes_through_the_gap_and_is_near_the_shortest_route():
    m = small_map(inflate=0.15, soft=0.1, soft_weight=0.0, unknown=0.0)
    wall_with_gap(m, gap_y=0.5)
    path = planner.plan(m, m.cost(), (0.5, -0.5), (3.5, -0.5))
    assert path is not None
    at_wall = path[np.argmin(np.abs(path[:, 0] - 2.0))]
    assert abs(at_wall[1] - 0.5) < 0.16                        # through the gap (0.3 wide after inflation)
    cost = m.cost()
    i, j, _ = m.cell(path)
    assert np.isfinite(cost[i, j]).all()
    # shortest route: two straight legs via the gap's near corner; an 8-connected grid is at most
    # 1/cos(22.5°) - 1 = 8.2 % longer than the straight line
    corner = np.array([2.0, 0.5 - 0.15])
    legs = np.linalg.norm(corner - (0.5, -0.5)) + np.linalg.norm((3.5, -0.5) - corner)
    length = np.linalg.norm(np.diff(path, axis=0), axis=1).sum()
    assert legs * 0.97 < length < legs * 1.09


def test_no_path_through_a_closed_wall_and_bad_goals_are_named():
    m = small_map(inflate=0.15)
    wall = np.array([[x, y, 0.3] for x in (1.98, 2.0, 2.02) for y in np.arange(-1.0, 1.0, 0.01)])
    m.add(np.vstack([flat_ground(), wall]))
    assert planner.plan(m, m.cost(), (0.5, 0.0), (3.5, 0.0)) is None
    with pytest.raises(ValueError, match="outside the cost map"):
        planner.plan(m, m.cost(), (0.5, 0.0), (9.0, 0.0))


def test_the_follower_bends_left_for_a_target_on_the_left_and_stops_the_screws():
    joints = ["bend_03", "twist_03", "screw_front_03", "bend_04", "bend_05", "bend_06"]
    p = follower.FollowerParams(bend_rate=1e9)                  # no rate limit: the law's target at once
    path = np.array([[0.0, 0.0], [1.0, 1.0], [3.0, 3.0]])      # heading +45° from a body along +x
    f = follower.Follower(joints, p)
    pos, vel = f.command((0.0, 0.0), (-3.0, 0.0), path, 0.01)
    assert pos[0] > p.trim and pos[1] == 0.0 and vel[2] == p.speed and vel[0] == 0.0
    right = follower.Follower(joints, p)
    pos_r, _ = right.command((0.0, 0.0), (-3.0, 0.0), path * [1, -1], 0.01)
    assert pos_r[0] < p.trim
    pos, vel = f.command((0.0, 0.0), (-3.0, 0.0), path, 0.01, stop=True)
    assert (vel == 0).all()
    with pytest.raises(ValueError, match="steer joints"):
        follower.Follower(["bend_00"], p)


def test_point_cloud2_read_by_hand_matches_rosbags_codec():
    pytest.importorskip("cyclonedds.idl")
    rosbags = pytest.importorskip("rosbags.typesys")
    messages = load("messages")
    ts = rosbags.get_typestore(rosbags.Stores.ROS2_HUMBLE)
    M = ts.types
    pts = np.zeros(7, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("pad", "<f4"), ("ring", "<u2"),
                             ("status", "u1"), ("pad2", "u1")])
    pts["x"], pts["y"], pts["z"], pts["ring"] = np.arange(7), -np.arange(7), 0.5, 2000 + np.arange(7)
    pts["pad"] = -0.01 * np.arange(7)
    # float32 x, y, z, the firing time t and the ground-truth label (uint16, datatype 4) where the sim's cloud has it
    fields = [M["sensor_msgs/msg/PointField"](name=n, offset=o, datatype=d, count=1)
              for n, o, d in (("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("t", 12, 7), ("label", 16, 4))]
    msg = M["sensor_msgs/msg/PointCloud2"](
        header=M["std_msgs/msg/Header"](stamp=M["builtin_interfaces/msg/Time"](sec=12, nanosec=345),
                                        frame_id="lidar_x"),
        height=1, width=7, fields=fields, is_bigendian=False, point_step=20, row_step=140,
        data=pts.view(np.uint8).reshape(-1), is_dense=True)
    cdr = bytes(ts.serialize_cdr(msg, "sensor_msgs/msg/PointCloud2"))
    got = messages.PointCloud2.deserialize(cdr)
    assert (got.header.stamp.sec, got.header.stamp.nanosec, got.header.frame_id) == (12, 345, "lidar_x")
    assert [f.name for f in got.fields] == ["x", "y", "z", "t", "label"]
    assert [f.offset for f in got.fields] == [0, 4, 8, 12, 16]
    assert (got.width, got.height, got.point_step, got.is_dense) == (7, 1, 20, True)
    assert got.data == pts.tobytes()
    node = load("node")
    xyz, fields = node.cloud_points(got)
    assert np.allclose(xyz, np.column_stack([np.arange(7), -np.arange(7), np.full(7, 0.5)]))
    assert fields["label"].tolist() == list(range(2000, 2007))
    assert fields["t"].tolist() == pytest.approx(-0.01 * np.arange(7))
    got.fields = got.fields[:3]                        # a cloud with neither: the points alone
    assert node.cloud_points(got)[1] == {}


def test_deskew_places_each_return_from_the_pose_its_beam_fired_at():
    # a lidar on a link turning at a steady 1.2 rad/s about a tilted axis while moving at 0.4 m/s: its pose is
    # the geodesic and the straight line between the sweep's ends, so deskewing recovers the world exactly
    from scipy.spatial.transform import Rotation
    rng = np.random.default_rng(3)
    T, stamp, w, v = 0.1, 7.3, 1.2 * np.array([0.2, -0.3, 0.93]) / np.linalg.norm([0.2, -0.3, 0.93]), [0.4, 0.1, 0.0]
    R_ls, p_ls = Rotation.from_euler("x", -np.pi / 2).as_matrix(), np.array([0.175, 0.1175, 0.0])
    R1, p1 = Rotation.from_euler("z", 0.4).as_matrix(), np.array([2.0, -1.0, 0.09])

    def link_at(tau):          # the link's pose at stamp + tau (tau <= 0)
        return Rotation.from_rotvec(np.outer(tau, w)).as_matrix() @ R1, p1 + np.outer(tau, v)

    world = rng.uniform([-3, -3, 0], [8, 3, 0.5], (500, 3))
    tau = -T * rng.integers(0, 1025, 500) / 1024               # a grid's columns' firing times
    R_l, p_l = link_at(tau)
    on_link = np.einsum("nji,nj->ni", R_l, world - p_l)       # R_lᵀ (x − p_l)
    local = (on_link - p_ls) @ R_ls                            # R_lsᵀ (x_l − p_ls), row-wise
    R0, p0 = link_at(np.array([-T]))
    got = deskew.deskew(local, tau.astype(np.float32), stamp, (stamp - T, R0[0], p0[0]), (stamp, R1, p1), (R_ls, p_ls))
    # float32 firing times: |w|·r·δτ with δτ ~ 4e-9 s
    np.testing.assert_allclose(got, world, atol=1e-6)
    # placed with the pose at the stamp instead: off by up to |w|·r·T, tens of cm at 8 m
    at_stamp = (local @ R_ls.T + p_ls) @ R1.T + p1
    assert np.abs(at_stamp - world).max() > 0.3
