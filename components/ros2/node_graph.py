"""ROS 2 node-graph presence: the ``ros_discovery_info`` announcement that makes ``ros2 node list`` show snakesim.

ROS 2's DDS middlewares (rmw_cyclonedds, rmw_fastrtps, through rmw_dds_common)
learn which DDS endpoints belong to which ROS node from one DDS topic,
``ros_discovery_info`` (no ``rt/`` prefix), type
``rmw_dds_common/msg/ParticipantEntitiesInfo``: each participant publishes its
gid and, for each node it hosts, the node's namespace and name and the gids of
the node's readers and writers, again whenever they change; QoS reliable,
transient local, keep last 1 (rmw_cyclonedds_cpp, rmw_node.cpp), so a tool
that starts later still gets it. A gid is the entity's 16-byte DDS GUID,
zero-padded to the distribution's ``Gid`` size: 24 bytes up to Humble, 16 from
Iron on (``rmw_dds_common/msg/Gid`` changed). The message type is built from
rosbags' definition of that distribution (``ros_distro``: ``humble``, the
default, or ``jazzy``). A Humble announcement read by a Jazzy node parses as a
participant with no nodes (the 16 GUID bytes fill its gid, the 8 zero padding
bytes read as an empty node list): harmless; the reverse would misparse, hence
Humble by default.

A snakesim process is one DDS participant per domain (:class:`.transport.SharedParticipant`) hosting
one node, ``/snakesim`` (:data:`NODE`): the publisher, the command sources, the simulation control, the
sensor bridge and odometry all add their readers and writers to it, so ``ros2 node list`` shows one
node and ``ros2 node info /snakesim`` lists every topic and service.
"""

from __future__ import annotations

TOPIC = "ros_discovery_info"
#: the one ROS node a snakesim process shows as
NODE = "snakesim"
DISTROS = {"humble": "ROS2_HUMBLE", "jazzy": "ROS2_JAZZY"}


def discovery_type(distro: str = "humble"):
    """ParticipantEntitiesInfo of ``distro``'s rmw_dds_common (Gid of 24 or 16 bytes)."""
    from .messages import ros_type

    return ros_type("rmw_dds_common/msg/ParticipantEntitiesInfo", store_name=DISTROS[distro])


def gid(entity, size: int) -> list[int]:
    """An entity's DDS GUID as rmw_dds_common's Gid data: 16 bytes, zero-padded to ``size``."""
    raw = entity.guid.bytes
    return list(raw) + [0] * (size - len(raw))


class NodeEntities:
    """The ``ros_discovery_info`` message of a participant that hosts one node ``namespace``/``node``.

    It describes; it writes nothing: the participant (:meth:`.transport.Ros2Participant.announce`) owns
    the writer and its QoS."""

    def __init__(self, node: str, namespace: str = "/", distro: str = "humble"):
        from .messages import ros_type

        if distro not in DISTROS:
            raise ValueError(f"ros_distro '{distro}': one of {', '.join(DISTROS)}")
        self.Info = discovery_type(distro)
        self.Node = ros_type("rmw_dds_common/msg/NodeEntitiesInfo", store_name=DISTROS[distro])
        self.Gid = ros_type("rmw_dds_common/msg/Gid", store_name=DISTROS[distro])
        self.size = len(self.Gid().data)
        self.node, self.namespace, self.distro = node, namespace, distro

    def message(self, participant, readers, writers):
        """``participant``'s ParticipantEntitiesInfo: the one node, with these readers and writers."""
        def g(entity):
            return self.Gid(data=gid(entity, self.size))

        return self.Info(gid=g(participant),
                         node_entities_info_seq=[self.Node(node_namespace=self.namespace, node_name=self.node,
                                                           reader_gid_seq=[g(r) for r in readers],
                                                           writer_gid_seq=[g(w) for w in writers])])

    def nodes_message(self, participant, nodes: dict):
        """``participant``'s ParticipantEntitiesInfo with several nodes: ``nodes`` maps a node name to its
        (readers, writers)."""
        def g(entity):
            return self.Gid(data=gid(entity, self.size))

        return self.Info(gid=g(participant),
                         node_entities_info_seq=[self.Node(node_namespace=self.namespace, node_name=name,
                                                           reader_gid_seq=[g(r) for r in readers],
                                                           writer_gid_seq=[g(w) for w in writers])
                                                 for name, (readers, writers) in nodes.items()])
