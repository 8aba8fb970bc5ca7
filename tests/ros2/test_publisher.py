"""The ros2_publisher sink in process: --ros2 wiring by role, per-topic rates, the cost of publishing."""

import threading
import time

import pytest

from snakesim.framework.assembly import resolve
from snakesim.framework.registry import default_registry
from snakesim.framework.session import Session


def _scene(*sets, duration=0.2):
    reg = default_registry()
    return resolve("robot-zero-g", search_path=reg.assembly_paths(),
                   overrides=["robot.modules=2", *sets], sim_overrides={"duration": duration}), reg


def test_attach_wires_by_role_and_publishes_at_each_topic_rate(dds_domain):
    from snakesim.components.ros2.attach import attach_ros2

    resolved, reg = _scene()
    name = attach_ros2(resolved, reg, params={"domain_id": dds_domain(), "rates": {"tf": 25.0}})
    assert attach_ros2(resolved, reg, params={"world_frame": "odom"}) == name      # once; params merged
    wired = {d.split(".")[1]: s for s, d, w in resolved.connections if w == "--ros2" and d.startswith(f"{name}.")}
    assert wired == {"link_poses": "robot.link_poses", "joint_positions": "robot.joint_q",
                     "joint_velocities": "robot.joint_v"}
    s = Session(resolved, reg)
    pub = s.plan.components[name]
    assert pub.rate == 100.0 and pub.p.world_frame == "odom"
    s.run()
    run = s.plan.caches[name]
    # 0.2 s: ticks at t = 0, 0.01, ..., 0.19 (and 0.2 when the last step's update runs)
    n = run.published
    assert n["clock"] in (20, 21) and n["joint_states"] == n["clock"]
    assert n["tf"] == (n["clock"] + 3) // 4
    assert "imu" not in n and "wrench" not in n
    per_tick = run.publish_time / n["clock"]
    print(f"publish cost: {1e6 * per_tick:.1f} µs per tick (clock, joint_states; tf every 4th), "
          f"{pub.nj} joints, {pub.nl} links")
    run.close()


def test_unknown_topic_rate_is_an_error(dds_domain):
    from snakesim.components.ros2.attach import attach_ros2
    from snakesim.framework import SnakesimError

    resolved, reg = _scene()
    attach_ros2(resolved, reg, params={"domain_id": dds_domain(), "rates": {"joints": 10.0}})
    with pytest.raises((SnakesimError, ValueError), match="unknown topics"):
        Session(resolved, reg)


def test_tf_static_has_the_fixed_joints_and_tf_leaves_their_links_out(dds_domain):
    import numpy as np
    from scipy.spatial.transform import Rotation

    from snakesim.components.ros2 import messages as M
    from snakesim.components.ros2.attach import attach_ros2
    from snakesim.components.ros2.transport import Ros2Participant

    domain = dds_domain()
    resolved, reg = _scene(duration=1.5)
    name = attach_ros2(resolved, reg, params={"domain_id": domain, "rates": {"real_time_factor": 20.0}})
    s = Session(resolved, reg)
    pub = s.plan.components[name]
    fixed = [j for j in pub.robot.tree.joints if j.type == "fixed"]
    assert fixed, "the test robot has fixed joints (head, imu, cameras, lidar)"
    static_links = {j.child for j in fixed}
    assert [pub.links[i] for i in pub.tf_rows] == [ln for ln in pub.links if ln not in static_links]
    # latched: a reader that joins after the run's first tick still gets it (the run paced to the wall
    # clock in a thread, the reader made 0.3 s in; the endpoints close when the run ends)
    runner = threading.Thread(target=s.run, kwargs={"realtime": True})
    runner.start()
    time.sleep(0.3)
    with Ros2Participant(domain) as dds:
        reader = dds.reader("/tf_static", M.TFMessage)
        msgs = []
        end = time.monotonic() + 5
        while not msgs and time.monotonic() < end:
            msgs = [m for m in reader.take(N=10) if isinstance(m, M.TFMessage)]
            time.sleep(0.01)
    runner.join(timeout=30)
    run = s.plan.caches[name]
    assert run.dds is None                  # closed when the run ended (ClosedAfterRun)
    assert len(msgs) == 1
    got = {tr.child_frame_id: tr for tr in msgs[0].transforms}
    assert set(got) == static_links
    for j in fixed:
        tr = got[j.child]
        assert tr.header.frame_id == j.parent
        v = tr.transform.translation
        assert np.allclose([v.x, v.y, v.z], j.translation)
        q = tr.transform.rotation
        assert np.allclose(Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix(), j.rotation, atol=1e-12)
    # the /tf template: only the non-static links, with their own rows of link_poses
    tpl = run.templates["tf"][2]
    assert len(tpl.selection["poses"]) == 7 * len(pub.tf_rows)


def test_real_time_factor_is_published_at_its_rate(dds_domain):
    from snakesim.components.ros2.attach import attach_ros2

    resolved, reg = _scene(duration=0.3)
    name = attach_ros2(resolved, reg, params={"domain_id": dds_domain(), "rates": {"real_time_factor": 20.0}})
    s = Session(resolved, reg)
    s.run()
    run = s.plan.caches[name]
    # ticks every 0.05 s: 0, 0.05, ..., 0.3 -> 7 ticks, published from the second on
    assert run.published["real_time_factor"] in (5, 6)
    assert run.real_time_factor > 0
    run.close()
