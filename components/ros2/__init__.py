"""ROS 2 interface: snakesim's topics on the real ROS 2 wire protocol (Cyclone DDS), no ROS installation.

    messages    the ROS 2 message types, generated from rosbags' standard definitions
    transport   a DDS participant on ROS 2's conventions (rt/ topics, QoS, loopback by default)
    template    messages serialised once and patched in place per publish
    publisher   the ros2_publisher sink (/clock, /joint_states, /tf, /robot_description, /imu, /fts/*)
    attach, cli ``snakesim run --ros2``: the publisher added and wired by port role
"""

from .publisher import Ros2Publisher

__all__ = ["Ros2Publisher"]
