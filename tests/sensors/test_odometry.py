"""Odometry: the truth is the multibody's link pose and child-frame twist; the noise-free estimate stays
within the derived integration bound; the noisy estimate's drift follows the model's law and its reported
covariance; seeded; clear errors; nav_msgs/Odometry bytes decode with rosbags; the MCAP gets both topics."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from snakesim.components.multibody import Multibody
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.sensors.odometry import Odometry
from snakesim.framework import Harness

MODEL = RobotModel.load(design="eels-1.5")
USES = {"robot": MODEL}
LINK = "module_02"


def _random_state(robot, rng):
    x = robot.x.copy()
    nq = robot.c.robot.nq
    x[:3] = rng.normal(size=3)
    x[3:7] = Rotation.random(random_state=rng).as_quat()
    x[7:nq] = rng.uniform(-0.6, 0.6, nq - 7)
    x[nq:] = rng.normal(size=len(x) - nq)
    return x


def test_truth_is_the_link_pose_and_the_twist_in_the_link_frame():
    rng = np.random.default_rng(3)
    robot = Harness(Multibody, {"design": "eels-1.5"}, name="robot")
    model = robot.c.robot
    robot.x[:] = _random_state(robot, rng)
    out = robot.outputs()
    for link in (LINK, model.tree.root):
        i = model.link_index(link)
        odo = Harness(Odometry, {"link": link}, uses={"robot": model})
        odo.inputs.link_poses = out["link_poses"]
        odo.inputs.link_velocities = out["link_velocities"]
        o = odo.outputs()
        R, v = out["link_rotations"][i], out["link_velocities"][i]
        np.testing.assert_allclose(o["pose"], out["link_poses"][i], rtol=0, atol=1e-12)
        np.testing.assert_allclose(o["twist"][:3], R.T @ v[:3], rtol=0, atol=1e-12)
        np.testing.assert_allclose(o["twist"][3:], R.T @ v[3:], rtol=0, atol=1e-12)
        assert np.abs(o["twist"][:3] - v[:3]).max() > 0.1          # the frame matters here
        # the first sample's estimate is the truth, its covariance 0
        np.testing.assert_array_equal(o["estimate_pose"], o["pose"])
        assert not o["estimate_pose_covariance"].any()
    # independently of the multibody's velocity outputs: the root's twist is the free-flyer's body velocity
    # (Pinocchio's local frame), and the module's follows from the pose moved ±h along the state's velocity
    root = Harness(Odometry, {}, uses={"robot": model})
    root.inputs.link_poses, root.inputs.link_velocities = out["link_poses"], out["link_velocities"]
    nq = model.nq
    np.testing.assert_allclose(root.outputs()["twist"], robot.x[nq:nq + 6], atol=1e-12)
    h, x0 = 1e-6, robot.x.copy()
    poses = []
    for s in (h, -h):
        dx = np.r_[s * x0[nq:], np.zeros(len(x0) - nq)]
        xs = np.empty_like(x0)
        robot.c.integrate(x0, dx, xs)
        robot.x[:] = xs
        poses.append(robot.outputs()["link_poses"][model.link_index(LINK)].copy())
    robot.x[:] = x0
    i = model.link_index(LINK)
    R = out["link_rotations"][i]
    v_fd = (poses[0][:3] - poses[1][:3]) / (2 * h)
    rp, rm = Rotation.from_quat(poses[0][3:]), Rotation.from_quat(poses[1][3:])
    w_body_fd = (rm.inv() * rp).as_rotvec() / (2 * h)              # R(-h)ᵀ R(+h) ≈ Exp(2h ω_body)
    odo = Harness(Odometry, {"link": LINK}, uses={"robot": model})
    odo.inputs.link_poses, odo.inputs.link_velocities = out["link_poses"], out["link_velocities"]
    tw = odo.outputs()["twist"]
    np.testing.assert_allclose(tw[:3], R.T @ v_fd, atol=1e-6)
    np.testing.assert_allclose(tw[3:], w_body_fd, atol=1e-6)


# -- a smooth 3-D motion given by its body twist, integrated to 1e-12 --------------------------------------
def _vb(t):
    return np.array([0.5 + 0.2 * np.sin(1.3 * t), 0.1 * np.cos(0.7 * t), 0.05 * np.sin(2.0 * t)])


def _wb(t):
    return np.array([0.3 * np.sin(0.9 * t), 0.2 * np.cos(1.1 * t), 0.4 + 0.1 * np.sin(1.7 * t)])


L_V = np.linalg.norm([0.2 * 1.3, 0.1 * 0.7, 0.05 * 2.0])           # ≥ max |v̇_b|
L_W = np.linalg.norm([0.3 * 0.9, 0.2 * 1.1, 0.1 * 1.7])            # ≥ max |ω̇_b|
V_MAX = np.linalg.norm([0.7, 0.1, 0.05])                            # ≥ max |v_b|
P0, Q0 = np.array([1.0, -2.0, 0.3]), Rotation.from_euler("xyz", [0.3, -0.2, 1.0]).as_quat()


def _reference(vb, wb, T):
    def f(t, s):
        R = Rotation.from_quat(s[3:]).as_matrix()
        x, y, z, w = s[3:]
        ox, oy, oz = wb(t)                                   # q̇ = ½ q ⊗ (ω_b, 0)
        dq = 0.5 * np.array([w * ox + y * oz - z * oy, w * oy + z * ox - x * oz, w * oz + x * oy - y * ox,
                             -x * ox - y * oy - z * oz])
        return np.r_[R @ vb(t), dq]
    return solve_ivp(f, (0.0, T), np.r_[P0, Q0], method="DOP853", rtol=1e-12, atol=1e-13, dense_output=True)


def _dead_reckon(sol, vb, wb, rate, T, params=None, link=LINK):
    """Feed the odometry the reference motion sampled at ``rate``: (t_k, truth pose, estimate pose, outputs)."""
    h = Harness(Odometry, {"link": link, **(params or {})}, rate=rate, uses=USES)
    i = MODEL.link_index(link)
    poses, vels = np.zeros((MODEL.nl, 7)), np.zeros((MODEL.nl, 6))
    poses[:, 6] = 1.0
    rows = []
    for k in range(int(round(T * rate)) + 1):
        t = k / rate
        s = sol.sol(t)
        q = s[3:] / np.linalg.norm(s[3:])
        R = Rotation.from_quat(q).as_matrix()
        poses[i] = np.r_[s[:3], q]
        vels[i] = np.r_[R @ vb(t), R @ wb(t)]
        h.inputs.link_poses, h.inputs.link_velocities = poses, vels
        o = h.outputs(t)
        rows.append((t, o["pose"].copy(), o["estimate_pose"].copy(), o))
        h.update(t)
    return rows


def _errors(rows):
    dp = np.array([np.linalg.norm(est[:3] - tru[:3]) for _t, tru, est, _o in rows])
    dth = np.array([(Rotation.from_quat(est[3:]) * Rotation.from_quat(tru[3:]).inv()).magnitude()
                    for _t, tru, est, _o in rows])
    return dp, dth


def test_noise_free_estimate_within_the_integration_bound_and_first_order():
    T = 4.0
    sol = _reference(_vb, _wb, T)
    worst = {}
    for rate in (50.0, 100.0):
        rows = _dead_reckon(sol, _vb, _wb, rate, T)
        dt = 1.0 / rate
        t = np.array([r[0] for r in rows])
        dp, dth = _errors(rows)
        bound_th = 0.5 * L_W * dt * t
        bound_p = dt * (0.25 * L_W * V_MAX * t ** 2 + 0.5 * L_V * t + L_W * V_MAX * dt * t / 6.0)
        assert np.all(dth <= bound_th + 1e-11), (dth - bound_th).max()
        assert np.all(dp <= bound_p + 1e-11), (dp - bound_p).max()
        worst[rate] = (dp[-1], dth[-1])
        assert dp[-1] > 0.02 * bound_p[-1]                          # the bound is not vacuous
        # the measured twist is the true one (no scale, bias or noise)
        np.testing.assert_allclose(rows[-1][3]["estimate_twist"], rows[-1][3]["twist"], atol=1e-15)
    # first order: half the step, half the error
    assert 1.7 < worst[50.0][0] / worst[100.0][0] < 2.3
    assert 1.7 < worst[50.0][1] / worst[100.0][1] < 2.3


def test_constant_body_twist_is_integrated_exactly():
    vb, wb, T = (lambda t: np.array([0.4, -0.1, 0.2])), (lambda t: np.array([0.3, -0.5, 0.8])), 3.0
    rows = _dead_reckon(_reference(vb, wb, T), vb, wb, 50.0, T)
    dp, dth = _errors(rows)
    assert dp.max() < 1e-10 and dth.max() < 1e-10


def test_scale_error_and_bias_are_deterministic_drift():
    vb, wb, T = (lambda t: np.array([0.5, 0.0, 0.0])), (lambda t: np.zeros(3)), 2.0
    rows = _dead_reckon(_reference(vb, wb, T), vb, wb, 50.0, T,
                        {"linear_scale_error": 0.1, "linear_bias": (0.0, 0.02, 0.0)})
    t, tru, est, o = rows[-1]
    R = Rotation.from_quat(Q0).as_matrix()
    np.testing.assert_allclose(est[:3] - tru[:3], R @ np.array([0.05, 0.02, 0.0]) * t, atol=1e-12)
    np.testing.assert_allclose(o["estimate_twist"][:3], [0.55, 0.02, 0.0], atol=1e-15)
    assert not o["estimate_pose_covariance"].any()                  # calibration errors: not random


# -- noise statistics over many seeds --------------------------------------------------------------------
def _run_seeds(params, seeds, n, rate=50.0, v_body=(1.0, 0.0, 0.0)):
    """Straight motion at constant body velocity with a fixed orientation: (errors [M, 6] of [δp, δθ] after
    n samples, the reported pose covariance, the reported twist covariance)."""
    i = MODEL.link_index(LINK)
    R = Rotation.from_quat(Q0).as_matrix()
    v_world = R @ np.asarray(v_body)
    poses, vels = np.zeros((MODEL.nl, 7)), np.zeros((MODEL.nl, 6))
    poses[:, 6] = 1.0
    vels[i, :3] = v_world
    errs = []
    for seed in seeds:
        h = Harness(Odometry, {"link": LINK, "seed": seed, **params}, rate=rate, uses=USES)
        h.inputs.link_velocities = vels
        for k in range(n + 1):
            poses[i] = np.r_[P0 + v_world * k / rate, Q0]
            h.inputs.link_poses = poses
            o = h.outputs(k / rate)
            if k < n:
                h.update(k / rate)
        est, tru = o["estimate_pose"], o["pose"]
        dth = (Rotation.from_quat(est[3:]) * Rotation.from_quat(tru[3:]).inv()).as_rotvec()
        errs.append(np.r_[est[:3] - tru[:3], dth])
    return np.array(errs), o["estimate_pose_covariance"], o["estimate_twist_covariance"]


def _chi2_ok(stat, dof, p=1e-3):
    return chi2.ppf(p / 2, dof) < stat < chi2.ppf(1 - p / 2, dof)


def test_velocity_noise_gives_a_random_walk_of_variance_sigma2_dt_t():
    sigma, rate, n, m = 0.05, 50.0, 40, 250
    dt, t = 1.0 / rate, n / rate
    e, P, Pt = _run_seeds({"linear_noise": sigma}, range(m), n, rate)
    law = sigma ** 2 * dt * t                                       # per axis, world frame
    np.testing.assert_allclose(P[:3, :3], law * np.eye(3), rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(Pt, np.diag([sigma ** 2] * 3 + [0.0] * 3), atol=1e-18)
    assert not e[:, 3:].any()                                       # no rotation noise: heading exact
    stat = float((e[:, :3] ** 2).sum() / law)
    assert _chi2_ok(stat, 3 * m), (stat, 3 * m)
    # and not a smaller or larger law: 1.5× the variance or 1/1.5 is rejected by the same test
    assert not _chi2_ok(stat / 1.5, 3 * m) and not _chi2_ok(stat * 1.5, 3 * m)


def test_bias_walk_and_rate_noise_drift_matches_the_reported_covariance():
    params = {"linear_noise": 0.02, "angular_noise": 0.01, "linear_bias_walk": 0.05, "angular_bias_walk": 0.02}
    rate, n, m = 50.0, 40, 200
    dt = 1.0 / rate
    e, P, Pt = _run_seeds(params, range(m), n, rate)
    # the bias walk's share in closed form: Var(δp) = σ_b² Δt³ Σ_{j=1}^{n-1} j² from the velocity bias,
    # Var(δθ) = σ_ω² Δt² n + σ_bω² Δt³ Σ j², as P reports along the motion's axis (no rotation coupling there)
    sj2 = sum(j * j for j in range(1, n))
    R = Rotation.from_quat(Q0).as_matrix()
    along = R[:, 0] @ P[:3, :3] @ R[:, 0]
    assert along == pytest.approx(0.02 ** 2 * dt ** 2 * n + 0.05 ** 2 * dt ** 3 * sj2, rel=1e-3)
    assert P[3, 3] == pytest.approx(0.01 ** 2 * dt ** 2 * n + 0.02 ** 2 * dt ** 3 * sj2, rel=1e-3)
    assert Pt[0, 0] == pytest.approx(0.02 ** 2 + 0.05 ** 2 * dt * n, rel=1e-12)
    # the drift over the seeds: Mahalanobis distances under the reported covariance are chi-square(6)
    Pinv = np.linalg.inv(P)
    stat = float(np.einsum("si,ij,sj->", e, Pinv, e))
    assert _chi2_ok(stat, 6 * m), (stat, 6 * m)
    # the heading error adds to the lateral drift only
    lateral = R[:, 1] @ P[:3, :3] @ R[:, 1]
    assert lateral > along


def test_same_seed_same_estimate_other_seed_other():
    params = {"linear_noise": 0.05, "angular_noise": 0.01, "angular_bias_walk": 0.01}
    a, _, _ = _run_seeds(params, [7, 7, 8], 10)
    np.testing.assert_array_equal(a[0], a[1])
    assert not np.array_equal(a[0], a[2])


def test_bad_params_name_the_key_and_the_valid_values():
    from pydantic import ValidationError

    with pytest.raises(ValidationError, match=r"linear_noise\n.*greater than or equal to 0"):
        Odometry("odo", {"linear_noise": -0.1}, uses=USES)
    with pytest.raises(ValidationError, match=r"angular_bias_walk\n.*greater than or equal to 0"):
        Odometry("odo", {"angular_bias_walk": -1.0}, uses=USES)
    with pytest.raises(ValidationError, match=r"linear_scale_error\n.*greater than -1"):
        Odometry("odo", {"linear_scale_error": -1.0}, uses=USES)
    with pytest.raises(ValueError, match=r"odo: link: 'nope' matches no name; valid: tail, knuckle_00"):
        Odometry("odo", {"link": "nope"}, uses=USES)
    with pytest.raises(ValueError, match=r"link must name one link, not a pattern: 'module_\*'; valid: tail"):
        Odometry("odo", {"link": "module_*"}, uses=USES)
    assert Odometry("odo", {}, uses=USES).link == MODEL.tree.root
    assert Odometry("odo", {}, uses=USES).rate == 50.0


# -- ROS 2: nav_msgs/Odometry bytes, and the MCAP recording --------------------------------------------
def test_odometry_message_round_trips_through_rosbags():
    pytest.importorskip("cyclonedds")
    from rosbags.typesys import Stores, get_typestore

    from snakesim.components.ros2.odometry_messages import ODOMETRY, OdometryTemplate, odometry_message

    ts = get_typestore(Stores.ROS2_HUMBLE)                      # the standard nav_msgs/msg/Odometry definition
    rng = np.random.default_rng(1)
    tpl = OdometryTemplate("world", LINK)
    for t in (0.0, 1.25, 123.456789012):
        pose = np.r_[rng.normal(size=3), Rotation.random(random_state=rng).as_quat()]
        twist, pc, tc = rng.normal(size=6), rng.normal(size=(6, 6)), rng.normal(size=(6, 6))
        buf = bytes(tpl.encode(t, pose, twist, pc, tc))
        m = ts.deserialize_cdr(buf, ODOMETRY)
        assert (m.header.frame_id, m.child_frame_id) == ("world", LINK)
        assert m.header.stamp.sec * 10 ** 9 + m.header.stamp.nanosec == round(t * 1e9)
        p, o = m.pose.pose.position, m.pose.pose.orientation
        np.testing.assert_array_equal([p.x, p.y, p.z, o.x, o.y, o.z, o.w], pose)
        lin, ang = m.twist.twist.linear, m.twist.twist.angular
        np.testing.assert_array_equal([lin.x, lin.y, lin.z, ang.x, ang.y, ang.z], twist)
        np.testing.assert_array_equal(m.pose.covariance, pc.ravel())
        np.testing.assert_array_equal(m.twist.covariance, tc.ravel())
        # the template's bytes are cyclonedds' own serialisation of the same message (padded to 4)
        raw = odometry_message(t, "world", LINK, pose, twist, pc, tc).serialize()
        assert buf[:len(raw)] == raw and not any(buf[len(raw):])
        # and rosbags' own serialisation decodes back the same
        assert ts.deserialize_cdr(ts.serialize_cdr(m, ODOMETRY), ODOMETRY).pose.covariance.tolist() == pc.ravel().tolist()


SCENE = """\
description: EELS 1.0 (2 modules) drifting in zero gravity, its odometry recorded
sim: {duration: 0.3, dt: 0.01, integrator: rk4}
components:
  robot: {type: multibody, params: {design: eels-1.0, modules: 2, gravity: [0, 0, 0],
                                    base_position: [0, 0, 0.3]}}
  odo: {type: odometry, params: {link: module_01, linear_noise: 0.01, angular_noise: 0.001, seed: 4}}
connections:
  - robot.link_poses -> odo.link_poses
  - robot.link_velocities -> odo.link_velocities
record: [odo.pose, odo.estimate_pose, robot.link_poses]
"""


def test_scene_records_odometry_and_the_mcap_has_both_topics(tmp_path):
    pytest.importorskip("cyclonedds")
    pytest.importorskip("mcap_ros2")
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    from snakesim.components.ros2.odometry_attach import ODOMETRY_BRIDGE, attach_odometry, attach_odometry_mcap
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry
    from snakesim.framework.session import Session

    scene = tmp_path / "odo.yaml"
    scene.write_text(SCENE)
    reg = default_registry()
    resolved = resolve(str(scene), search_path=reg.assembly_paths())
    bridge = attach_odometry(resolved, reg)
    assert resolved.components[bridge].rate == pytest.approx(50.0)
    rec = attach_odometry_mcap(resolved, str(tmp_path / "run.mcap"), reg)
    # the file recorder alone (no DDS in this test): the DDS sink and its wires removed
    del resolved.components[bridge]
    resolved.connections[:] = [c for c in resolved.connections if not c[1].startswith(f"{bridge}.")]
    s = Session(resolved, reg)
    res = s.run()
    s.plan.caches[rec].close()
    assert s.plan.components[rec].type_name == "ros2_odometry_mcap" and ODOMETRY_BRIDGE not in s.plan.components
    got = {}
    with open(tmp_path / "run.mcap", "rb") as f:
        for schema, channel, message, decoded in make_reader(
                f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            assert schema.name == "nav_msgs/msg/Odometry" and channel.message_encoding == "cdr"
            got.setdefault(channel.topic, []).append((message.log_time, decoded))
    assert set(got) == {"/odom", "/odom/ground_truth"}
    times = [t for t, _ in got["/odom/ground_truth"]]
    assert times == [round(k * 0.02 * 1e9) for k in range(len(times))] and len(times) >= 14
    assert [t for t, _ in got["/odom"]] == times
    # the recorded truth (sampled at 50 Hz, held between) is the link's recorded pose at the samples
    row = s.plan.components["odo"].robot.link_index("module_01")
    t_log = res["t"]
    poses = res["robot.link_poses"].reshape(len(t_log), -1, 7)[:, row]
    at = {round(t * 1e9): k for k, t in enumerate(t_log)}
    for (t_ns, truth), (_t, est) in zip(got["/odom/ground_truth"], got["/odom"]):
        assert (truth.header.frame_id, truth.child_frame_id) == ("world", "module_01")
        assert (est.header.frame_id, est.child_frame_id) == ("world", "module_01")
        p, o = truth.pose.pose.position, truth.pose.pose.orientation
        if t_ns in at:
            np.testing.assert_allclose([p.x, p.y, p.z, o.x, o.y, o.z, o.w], poses[at[t_ns]], atol=1e-12)
            np.testing.assert_allclose(res["odo.pose"][at[t_ns]], poses[at[t_ns]], atol=1e-12)
        assert not any(truth.pose.covariance) and est.pose.covariance[0] == pytest.approx(
            0.01 ** 2 * 0.02 ** 2 * round(t_ns / 2e7), rel=1e-3, abs=1e-18)
