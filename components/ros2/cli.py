"""``snakesim run --ros2``: the robot's topics on ROS 2 (registered through ``snakesim_run_options``).

    --ros2                    add a ros2_publisher, wired by port role (:mod:`.attach`)
    --ros2-domain N           DDS domain id (default ROS_DOMAIN_ID, else 0); implies --ros2
    --ros2-interface IF       network interface or address (default 127.0.0.1: this machine only,
                              no multicast); implies --ros2
    --ros2-distro D           humble (default) or jazzy: the node-graph announcement's layout
                              (ros_discovery_info, :mod:`.node_graph`); implies --ros2
    --ros2-rate TOPIC=HZ      per-topic rate (clock, joint_states, tf, imu, wrench, real_time_factor;
                              0: off), repeatable; a topic faster than the scene's base step is published
                              at every step (the step is never shortened for it; the log says the rate
                              it gets); implies --ros2
    --ros2-commands           hand the PID's set-points to ROS 2 (/joint_commands, /joint_command): the
                              scene's connections into pid.setpoint and pid.rate_ref are replaced by the
                              ros2_commands source's; implies --ros2. Without it, --ros2 accepts joint
                              commands only for a PID whose set-points the scene leaves unconnected
                              (/enable_gravity is accepted whenever the multibody's gravity input is free)
    --ros2-lockstep           the run holds at each control period (100 Hz, or every base step when the
                              step is longer) until a command or a /sim/step arrives
                              (:mod:`.sim_control`); implies --ros2
    --ros2-paused             start held at t0 (/sim/pause false or /sim/step N to go on); implies --ros2
    --ros2-hold-timeout S     stop the run after S wall seconds held with no request (default 0: wait
                              for ever); implies --ros2

--ros2 always adds the ros2_sim_control gate (:mod:`.sim_control`): /sim/pause (std_msgs/Bool), /sim/step
(std_msgs/UInt32), /sim/reset (std_msgs/Empty) and the services /sim/reset (std_srvs/srv/Empty) and
/sim/pause (std_srvs/srv/SetBool); with a multibody robot also /sim/set_pose (geometry_msgs/PoseStamped)
and /sim/set_joint_positions (sensor_msgs/JointState). With a ``tethers`` component whose ``attached``
input the scene leaves free it adds the ros2_tether_commands source: /tethers/attached
(std_msgs/UInt8MultiArray). These are harmless when unused (nothing changes until a request arrives),
so they are on by default.
"""

from __future__ import annotations

import click

from snakesim.framework import hookimpl


def _ros2(resolved, value):
    if value:
        from .attach import attach_ros2

        attach_ros2(resolved)


def _domain(resolved, value):
    from .attach import attach_ros2

    attach_ros2(resolved, params={"domain_id": int(value)})


def _interface(resolved, value):
    from .attach import attach_ros2

    attach_ros2(resolved, params={"interface": value})


def _distro(resolved, value):
    from .attach import attach_ros2

    attach_ros2(resolved, params={"ros_distro": value})


def _rates(resolved, value):
    from .attach import attach_ros2

    if not value:
        return
    rates = {}
    for item in value:
        topic, _, hz = item.partition("=")
        try:
            rates[topic.strip()] = float(hz)
        except ValueError:
            raise click.BadParameter(f"'{item}': expected TOPIC=HZ, e.g. joint_states=50",
                                     param_hint="--ros2-rate") from None
    name = attach_ros2(resolved)
    spec = resolved.components[name]
    merged = {**spec.params.get("rates", {}), **rates}
    attach_ros2(resolved, params={"rates": merged})
    # the publisher ticks at the fastest topic rate, at most once a base step: recompute it
    from snakesim.framework.rates import nearest_period

    from .publisher import DEFAULT_RATES

    fastest = max((r for r in {**DEFAULT_RATES, **merged}.values() if r > 0), default=1.0)
    dt = resolved.sim.dt
    resolved.components[name] = resolved.components[name].model_copy(
        update={"rate": 1.0 / (nearest_period(fastest, dt) * dt)})
    from .mcap_recorder import sync_recorder

    sync_recorder(resolved, name)          # a --ros2-mcap recorder mirrors the publisher's rates


def _commands(resolved, value):
    if not value:
        return
    from .attach import SHARED, attach_commands, attach_ros2

    name = attach_ros2(resolved)
    pub = resolved.components[name].params
    attach_commands(resolved, params={k: pub[k] for k in SHARED if k in pub}, takeover=True)


def _sim(**params):
    def apply(resolved, value):
        if value is None or value is False:
            return
        from .attach import attach_ros2, attach_sim_control

        attach_ros2(resolved)
        attach_sim_control(resolved, {k: (value if v is None else v) for k, v in params.items()})
    return apply


@hookimpl(specname="snakesim_run_options")
def ros2_run_options():
    options = [
        (click.Option(["--ros2"], is_flag=True, default=None,
                      help="Publish the robot on ROS 2 (Cyclone DDS; /clock, /joint_states, /tf, /tf_static, "
                           "/robot_description, /sim/real_time_factor, /imu, /fts/*, lidar PointCloud2 and camera Image/CameraInfo, "
                           "/odom and /terrain_map/* (--odometry, --terrain-map) when present; "
                           "/sim/pause, /sim/step, /sim/reset, /sim/set_pose, /sim/set_joint_positions, "
                           "/tethers/attached and the /sim/reset and /sim/pause services accepted); loopback only "
                           "by default."), _ros2),
        (click.Option(["--ros2-domain"], type=click.IntRange(0, 232), default=None,
                      help="ROS 2 domain id (default: ROS_DOMAIN_ID, else 0); implies --ros2."), _domain),
        (click.Option(["--ros2-interface"], default=None,
                      help="Network interface or address for ROS 2 (default 127.0.0.1: this machine only, "
                           "no multicast); implies --ros2."), _interface),
        (click.Option(["--ros2-distro"], type=click.Choice(["humble", "jazzy"]), default=None,
                      help="ROS 2 distribution of the nodes that list snakesim's node graph (ros_discovery_info: "
                           "its Gid layout changed after Humble; default humble); implies --ros2."), _distro),
        (click.Option(["--ros2-rate"], multiple=True, default=None, metavar="TOPIC=HZ",
                      help="ROS 2 topic rate: clock, joint_states, tf, imu, wrench, real_time_factor (0: off); a topic "
                           "faster than the base step is published every step; repeatable; implies --ros2."), _rates),
        (click.Option(["--ros2-commands"], is_flag=True, default=None,
                      help="Hand the PID's set-points to ROS 2 (/joint_commands JointTrajectory, /joint_command "
                           "JointState), replacing the scene's set-point source; implies --ros2."), _commands),
        (click.Option(["--ros2-lockstep"], is_flag=True, default=None,
                      help="Hold the run at each control period until a ROS 2 command or /sim/step arrives "
                           "(the world never runs ahead of the autonomy); implies --ros2."), _sim(lockstep=True)),
        (click.Option(["--ros2-paused"], is_flag=True, default=None,
                      help="Start held at t0 until /sim/pause false or /sim/step N; implies --ros2."),
         _sim(start_paused=True)),
        (click.Option(["--ros2-hold-timeout"], type=click.FloatRange(min=0), default=None, metavar="S",
                      help="Stop the run after S wall seconds held with no ROS 2 request (0: wait for ever); "
                           "implies --ros2."), _sim(hold_timeout=None)),
    ]
    # the interface publishes what it finds (sensors --lidar/--stereo add): applied after them
    for _, apply in options:
        apply.adds_sink = True
    return options
