"""The ros2_publisher sink in process: --ros2 wiring by role, per-topic rates, the cost of publishing."""

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
