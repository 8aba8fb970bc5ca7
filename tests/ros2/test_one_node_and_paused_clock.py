"""Item 8 of issue 26, seen from separate processes: a `snakesim run --ros2` process is one DDS participant and
one ROS node `/snakesim` holding every topic (graph_listener.py), its paused /clock goes on at its rate with the
held stamp (sim_client.py), it says its domain, interface and topics once at the start (not with --quiet), and
the QoS table comes from the code."""

import json

import pytest

from ros2_peer import run_beside


@pytest.mark.slow
def test_one_node_snakesim_with_every_topic(dds_domain):
    domain = dds_domain()
    got, _ = run_beside(("graph_listener.py", domain, 30),
                        ["robot-zero-g", "--set", "robot.modules=2", "--duration", "2.0", "--realtime",
                         "--ros2-domain", domain, "--quiet"], timeout=90, peer_timeout=40)
    assert [n["name"] for n in got["nodes"]] == ["snakesim"], got["nodes"]
    node = got["nodes"][0]
    pubs = {p["key"]: p for p in got["publications"]}
    writers = {pubs[g[:32]]["topic"] for g in node["writers"] if g[:32] in pubs}
    assert {"rt/clock", "rt/joint_states", "rt/tf", "rt/tf_static", "rt/robot_description",
            "rt/sim/real_time_factor", "rr/sim/resetReply", "rr/sim/pauseReply"} <= writers, sorted(writers)
    # the readers of the command source and of the gate are the same node's (no DCPSSubscription here: count)
    assert len(node["readers"]) >= 8
    # every writer of the run is on one participant, the node's
    run_parts = {p["participant"] for p in got["publications"] if p["key"] in {g[:32] for g in node["writers"]}}
    assert run_parts == {node["participant"][:32]}
    # ... and that participant is the run's only one: no other writer of the run's topics elsewhere
    others = {p["participant"] for p in got["publications"] if p["topic"] in ("rt/clock", "rt/sim/pauseReply")}
    assert others == {node["participant"][:32]}


@pytest.mark.slow
def test_paused_clock_keeps_publishing_the_held_stamp(dds_domain):
    domain = dds_domain()
    script = [{"at": 0.0, "sleep": 1.0},
              {"at": 0.0, "topic": "/sim/pause", "type": "Bool", "msg": {"data": False}}]
    got, run = run_beside(("sim_client.py", domain, 30, json.dumps(script)),
                          ["robot-zero-g", "--set", "robot.modules=2", "--duration", "0.3", "--realtime",
                           "--ros2-paused", "--ros2-hold-timeout", "20", "--ros2-domain", domain, "--quiet"],
                          timeout=90, peer_timeout=40)
    sleep, resume = got["steps"]
    held = [(w, ns) for w, ns in got["clock"] if sleep["wall"] + 0.1 < w < resume["wall"]]
    # paused at t0 for ~1 s: /clock at its 100 Hz (wall) all along, every stamp the held time
    assert len(held) >= 40, len(held)
    assert {ns for _, ns in held} == {0}
    gaps = [b[0] - a[0] for a, b in zip(held, held[1:])]
    assert max(gaps) < 0.2, max(gaps)
    # resumed: time goes on to the end of the run
    assert max(ns for _, ns in got["clock"]) >= 0.29e9


@pytest.mark.slow
def test_start_print_names_domain_interface_and_topics(dds_domain, tmp_path):
    import subprocess

    from ros2_peer import SNAKESIM, peer_env

    domain = dds_domain()
    args = [str(SNAKESIM), "run", "robot-zero-g", "--set", "robot.modules=2", "--duration", "0.05",
            "--ros2-domain", str(domain)]
    loud = subprocess.run(args, capture_output=True, text=True, timeout=90, env=peer_env())
    assert loud.returncode == 0, loud.stderr[-3000:]
    assert f"ROS 2: domain {domain}, interface 127.0.0.1" in loud.stderr and "node /snakesim" in loud.stderr
    lines = {ln.split()[0]: ln.split() for ln in loud.stderr.splitlines() if ln.startswith("  /")}
    assert lines["/clock"][1:3] == ["pub", "rosgraph_msgs/msg/Clock"] and "best effort" in " ".join(lines["/clock"])
    assert lines["/sim/pause"][1:3] == ["sub", "std_msgs/msg/Bool"]
    assert "transient local" in " ".join(lines["/tf_static"])
    assert loud.stderr.count("ROS 2: domain") == 1
    quiet = subprocess.run(args + ["--quiet"], capture_output=True, text=True, timeout=90, env=peer_env())
    assert quiet.returncode == 0 and "ROS 2: domain" not in quiet.stderr


def test_qos_table_from_the_code():
    from snakesim.components.ros2.qos_table import CLOCK_NOTE, catalogue_rows, markdown
    from snakesim.components.ros2.sensor_bridge import SENSOR_QOS
    from snakesim.components.ros2.transport import QOS

    rows = {r[0]: r for r in catalogue_rows()}
    assert rows["/clock"][3:] == ("best effort", "volatile", "keep last 1")
    assert rows["/tf"][5] == f"keep last {QOS['/tf'].depth}"
    assert rows["/tf_static"][4] == rows["/robot_description"][4] == "transient local"
    assert rows["/<lidar>/points"][5] == f"keep last {SENSOR_QOS.depth}"
    md = markdown()
    assert md.startswith("| Topic |") and "| `/clock` | pub | `rosgraph_msgs/msg/Clock` | best effort |" in md
    assert "reliable receives nothing" in CLOCK_NOTE and CLOCK_NOTE in md


def test_handles_share_one_participant_and_node(dds_domain):
    """In one process, every Ros2Participant on a domain is a handle onto one DDS participant; the announcement
    lists the endpoints of the handles that announced, and drops a handle's when it closes."""
    from snakesim.components.ros2 import messages as M
    from snakesim.components.ros2.transport import Ros2Participant

    domain = dds_domain()
    a, b = Ros2Participant(domain), Ros2Participant(domain)
    try:
        assert a.participant is b.participant
        wa, rb = a.writer("/x", M.Bool), b.reader("/y", M.Bool)
        a.announce("snakesim")
        b.announce("snakesim")
        nodes = a._shared.nodes()
        assert list(nodes) == ["snakesim"] and nodes["snakesim"] == ([rb], [wa])
        b.close()
        assert a._shared.nodes()["snakesim"] == ([], [wa])
        assert [r[0] for r in a.shared_endpoints()] == ["/x"]
    finally:
        a.close()
        b.close()
