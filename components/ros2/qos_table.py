"""The ROS 2 interface's topics and their QoS as rows, from the code (:data:`.transport.QOS`, the sensor
bridge's ``SENSOR_QOS``, the components' topic constants): one source for the start-of-run print of
``snakesim run --ros2`` (:func:`endpoint_rows`, what the run opened) and for the docs (:func:`catalogue_rows`,
:func:`markdown`).

A row: (topic, direction ``pub``/``sub``, type, reliability, durability, history). ``/clock`` is best effort
(rclcpp's ClockQoS): a reader that asks for reliable receives nothing from it (DDS matches a reliable
reader only with a reliable writer), as with any ROS 2 clock publisher.
"""

from __future__ import annotations

from .transport import DEFAULT_QOS, QOS, TopicQos

#: columns of a row
COLUMNS = ("topic", "direction", "type", "reliability", "durability", "history")

CLOCK_NOTE = ("/clock is best effort, like rclcpp's ClockQoS: a subscriber that asks for reliable receives "
              "nothing (DDS never matches a reliable reader with a best-effort writer); subscribe with best "
              "effort (rclcpp::ClockQoS, or `ros2 topic echo --qos-reliability best_effort /clock`). While "
              "the run is paused /clock goes on at its rate with the held time.")


def qos_cells(q: TopicQos) -> tuple[str, str, str]:
    """(reliability, durability, history) of a :class:`.transport.TopicQos`, in ROS 2's words."""
    return ("reliable" if q.reliable else "best effort", "transient local" if q.transient_local else "volatile",
            f"keep last {q.depth}")


def row(topic: str, direction: str, type_name: str, q: TopicQos | None = None) -> tuple:
    return (topic, direction, type_name, *qos_cells(q or QOS.get(topic, DEFAULT_QOS)))


def catalogue_rows() -> list[tuple]:
    """Every topic ``snakesim run --ros2`` may offer (which ones depend on the scene and flags; sensor
    topics are named after their sensor, ``/<component>/<port>/...``), with its QoS from the code."""
    from .brace_commands import BRACE_TOPIC
    from .commands import GRAVITY_TOPIC, JOINT_TOPIC, TRAJECTORY_TOPIC
    from .gait_commands import GAIT_TOPIC
    from .odometry_attach import ESTIMATE_TOPIC, TRUTH_TOPIC
    from .placement_requests import JOINTS_TOPIC, POSE_TOPIC
    from .publisher import RTF_TOPIC
    from .sensor_bridge import SENSOR_QOS
    from .sim_control import PAUSE_TOPIC, RESET_TOPIC, STEP_TOPIC
    from .tether_commands import TETHER_TOPIC
    from .terrain_map_attach import COSTMAP_TOPIC, ELEVATION_TOPIC, MAP_QOS

    pub = [("/clock", "rosgraph_msgs/msg/Clock"), ("/joint_states", "sensor_msgs/msg/JointState"),
           ("/tf", "tf2_msgs/msg/TFMessage"), ("/tf_static", "tf2_msgs/msg/TFMessage"),
           ("/robot_description", "std_msgs/msg/String"), (RTF_TOPIC, "std_msgs/msg/Float64"),
           ("/imu", "sensor_msgs/msg/Imu"), ("/fts/<joint>", "geometry_msgs/msg/WrenchStamped"),
           (TRUTH_TOPIC, "nav_msgs/msg/Odometry"), (ESTIMATE_TOPIC, "nav_msgs/msg/Odometry")]
    sensors = [("/<lidar>/points", "sensor_msgs/msg/PointCloud2"), ("/<camera>/image_raw", "sensor_msgs/msg/Image"),
               ("/<camera>/depth", "sensor_msgs/msg/Image"), ("/<camera>/labels", "sensor_msgs/msg/Image"),
               ("/<camera>/camera_info", "sensor_msgs/msg/CameraInfo")]
    sub = [(TRAJECTORY_TOPIC, "trajectory_msgs/msg/JointTrajectory"), (JOINT_TOPIC, "sensor_msgs/msg/JointState"),
           (GRAVITY_TOPIC, "std_msgs/msg/Bool"), (PAUSE_TOPIC, "std_msgs/msg/Bool"),
           (STEP_TOPIC, "std_msgs/msg/UInt32"), (RESET_TOPIC, "std_msgs/msg/Empty"),
           (POSE_TOPIC, "geometry_msgs/msg/PoseStamped"), (JOINTS_TOPIC, "sensor_msgs/msg/JointState"),
           (TETHER_TOPIC, "std_msgs/msg/UInt8MultiArray"), (GAIT_TOPIC, "rcl_interfaces/msg/ParameterEvent"),
           (BRACE_TOPIC, "rcl_interfaces/msg/ParameterEvent")]
    maps = [(COSTMAP_TOPIC, "nav_msgs/msg/OccupancyGrid"), (ELEVATION_TOPIC, "grid_map_msgs/msg/GridMap")]
    return ([row(t, "pub", ty) for t, ty in pub] + [row(t, "pub", ty, MAP_QOS) for t, ty in maps]
            + [row(t, "pub", ty, SENSOR_QOS) for t, ty in sensors]
            + [row(t, "sub", ty) for t, ty in sub])


def endpoint_rows(dds) -> list[tuple]:
    """The rows of what a process has open on ``dds``'s domain (every handle of its shared participant,
    :class:`.transport.SharedParticipant`), services and ``ros_discovery_info`` left out, sorted."""
    return sorted(set(dds.shared_endpoints()))


def start_lines(dds) -> list[str]:
    """What ``snakesim run --ros2`` says once at the start: domain, interface, node and the topics open."""
    iface = dds.interface + (" (this machine only, no multicast)" if dds.interface in ("127.0.0.1", "lo", "localhost")
                             else "")
    return ([f"ROS 2: domain {dds.domain_id}, interface {iface}, node /snakesim"]
            + ["  " + ln for ln in format_rows(endpoint_rows(dds))])


def print_start(dds) -> None:
    """Print :func:`start_lines` on stderr when run from the ``snakesim run`` command line without
    ``--quiet`` (nothing from the Python API or with ``--quiet``)."""
    import click

    ctx = click.get_current_context(silent=True)
    if ctx is None or "quiet" not in ctx.params or ctx.params.get("quiet"):
        return
    click.echo("\n".join(start_lines(dds)), err=True)


def format_rows(rows, header: bool = True) -> list[str]:
    """Aligned text lines (the start print)."""
    rows = [tuple(map(str, r)) for r in rows]
    table = ([COLUMNS] if header else []) + rows
    widths = [max(len(r[i]) for r in table) for i in range(len(COLUMNS))]
    return ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in table]


def markdown(rows=None) -> str:
    """A Markdown table (default: :func:`catalogue_rows`) and the /clock note."""
    rows = catalogue_rows() if rows is None else rows
    head = "| Topic | Direction | Type | Reliability | Durability | History |"
    lines = [head, "|---|---|---|---|---|---|"]
    lines += [f"| `{t}` | {d} | `{ty}` | {r} | {du} | {h} |" for t, d, ty, r, du, h in rows]
    return "\n".join(lines) + "\n\n" + CLOCK_NOTE + "\n"


if __name__ == "__main__":          # python -m snakesim.components.ros2.qos_table: the docs' table
    print(markdown())
