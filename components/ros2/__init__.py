"""ROS 2 interface: snakesim's topics on the real ROS 2 wire protocol (Cyclone DDS), no ROS installation.

    messages    the ROS 2 message types, generated from rosbags' standard definitions
    transport   a DDS participant on ROS 2's conventions (rt/ topics, QoS, loopback by default)
    template    messages serialised once and patched in place per publish
    publisher   the ros2_publisher sink (/clock, /joint_states, /tf, /robot_description, /imu, /fts/*)
    commands    the ros2_commands source (/joint_commands, /joint_command, /enable_gravity), validated
    tether_commands  the ros2_tether_commands source (/tethers/attached), validated
    rejections  Rejected (a reason naming the field) and the rate-limited rejection log
    sim_control the ros2_sim_control gate and state editor: /sim/pause, /sim/step N, lockstep
                (--ros2-lockstep), /sim/reset, /sim/set_pose, /sim/set_joint_positions, services
    placement_requests  /sim/set_pose and /sim/set_joint_positions validated into state writes
    services    ROS 2 services on rmw_cyclonedds' conventions (rq/…Request, rr/…Reply, request header)
    mcap_recorder, mcap_cli  the published topics recorded to MCAP (``--ros2-mcap FILE``)
    attach, cli ``snakesim run --ros2``: publisher, command sources and sim control added and wired
"""

from .commands import Ros2Commands
from .publisher import Ros2Publisher
from .sensor_bridge import Ros2SensorBridge
from .sim_control import Ros2SimControl
from .tether_commands import Ros2TetherCommands

__all__ = ["Ros2Commands", "Ros2Publisher", "Ros2SensorBridge", "Ros2SimControl", "Ros2TetherCommands"]
