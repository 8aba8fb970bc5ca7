"""ROS 2 interface: snakesim's topics on the real ROS 2 wire protocol (Cyclone DDS), no ROS installation.

    messages    the ROS 2 message types, generated from rosbags' standard definitions
    transport   a DDS participant on ROS 2's conventions (rt/ topics, QoS, loopback by default)
    template    messages serialised once and patched in place per publish
    publisher   the ros2_publisher sink (/clock, /joint_states, /tf, /robot_description, /imu, /fts/*)
    commands    the ros2_commands source (/joint_commands, /joint_command, /enable_gravity), validated
    sim_control the ros2_sim_control gate: /sim/pause, /sim/step N, lockstep (--ros2-lockstep)
    attach, cli ``snakesim run --ros2``: publisher and command source added and wired by port role
"""

from .commands import Ros2Commands
from .publisher import Ros2Publisher
from .sim_control import Ros2SimControl

__all__ = ["Ros2Commands", "Ros2Publisher", "Ros2SimControl"]
