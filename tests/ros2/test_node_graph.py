"""ROS 2 node-graph presence: `snakesim run --ros2` announces its nodes on ros_discovery_info as rmw_cyclonedds
does, seen by a separate process (graph_listener.py) that reads it with Humble's rmw_dds_common definition and
matches the gids against DDS's own discovery of the writers."""

import pytest

from ros2_peer import run_beside


@pytest.mark.slow
def test_ros2_node_list_would_show_snakesim_with_its_topics(dds_domain):
    domain = dds_domain()
    got, _ = run_beside(("graph_listener.py", domain, 30),
                        ["robot-zero-g", "--set", "robot.modules=2", "--duration", "2.0", "--realtime",
                         "--ros2-domain", domain, "--quiet"], timeout=90, peer_timeout=40)
    nodes = {n["name"]: n for n in got["nodes"]}
    assert set(nodes) == {"snakesim"}, sorted(nodes)            # one node per process (rclcpp's layout)
    node = nodes["snakesim"]
    assert node["namespace"] == "/"
    pubs = {p["key"]: p for p in got["publications"]}
    # Humble's Gid: the 16-byte DDS GUID, then 8 zero bytes
    assert all(len(g) == 48 and g.endswith("00" * 8) for g in node["writers"] + [node["participant"]])
    topics = {pubs[g[:32]]["topic"] for g in node["writers"] if g[:32] in pubs}
    assert {"rt/clock", "rt/joint_states", "rt/tf", "rt/robot_description"} <= topics, sorted(topics)
    # the node's participant is the one DDS says those writers belong to
    assert {pubs[g[:32]]["participant"] for g in node["writers"] if g[:32] in pubs} == {node["participant"][:32]}
    # the same node lists the gate's readers (/sim/pause …) and its service endpoints
    assert node["readers"] and any(pubs.get(g[:32], {}).get("topic") == "rr/sim/resetReply" for g in node["writers"])


def test_jazzy_layout_has_16_byte_gids():
    from snakesim.components.ros2.node_graph import discovery_type

    assert len(discovery_type("jazzy")().gid.data) == 16 and len(discovery_type("humble")().gid.data) == 24
    with pytest.raises(KeyError):
        discovery_type("rolling")
