"""``snakesim run --ros2-mcap FILE --odometry``: the odometry option is applied before the ROS 2 sinks (which
wire what they find), so the MCAP file has /odom and /odom/ground_truth."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from snakesim.framework.cli import cli, install_plugin_cli


def _invoke(*args, catch=False):
    install_plugin_cli()
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=catch)


def _mcap_topics(path):
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        s = make_reader(f).get_summary()
    return {c.topic: s.statistics.channel_message_counts.get(i, 0) for i, c in s.channels.items()}


def test_options_in_cli_order_put_odometry_in_the_mcap(tmp_path):
    """``--ros2-mcap FILE --odometry`` as the command line applies them (framework/cli.py _session): the
    odometry first, then the sinks; run here with the file recorders only (no DDS)."""
    pytest.importorskip("mcap")
    from snakesim.framework.cli import _session

    install_plugin_cli()
    path = tmp_path / "run.mcap"
    s = _session(None, (), [], extras={"ros2_mcap": str(path), "odometry": ""}, duration=0.2)
    types = {n: spec.type for n, spec in s.resolved.components.items()}
    assert types["odometry"] == "odometry"
    assert "ros2_odometry" in types.values() and "ros2_odometry_mcap" in types.values()
    rec = next(n for n, t in types.items() if t == "ros2_odometry_mcap")
    wired = {dst.split(".", 1)[1] for src, dst, *_ in s.resolved.connections if dst.startswith(f"{rec}.")}
    assert {"pose", "twist", "estimate_pose", "estimate_twist"} <= wired
    # keep the odometry file recorder only: nothing opens DDS in this test
    from snakesim.framework.session import Session

    resolved = s.resolved
    drop = [n for n, spec in resolved.components.items()
            if resolved.where.get(n) in ("--ros2", "--ros2-mcap") and n != rec]
    for n in drop:
        del resolved.components[n]
    resolved.connections[:] = [c for c in resolved.connections
                               if c[0].split(".", 1)[0] not in drop and c[1].split(".", 1)[0] not in drop]
    s = Session(resolved, s.registry)
    s.run()
    s.plan.caches[rec].close()
    topics = _mcap_topics(path)
    assert set(topics) == {"/odom", "/odom/ground_truth"} and min(topics.values()) >= 10


def test_ros2_mcap_command_line_records_odom(dds_domain, tmp_path):
    pytest.importorskip("mcap")
    path = tmp_path / "run.mcap"
    r = _invoke("run", "--ros2-mcap", path, "--odometry", "--ros2-domain", dds_domain(), "--duration", 0.2,
                "--quiet", catch=True)
    assert r.exit_code == 0, (r.output, r.exception)
    topics = _mcap_topics(path)
    assert topics.get("/odom", 0) >= 10 and topics.get("/odom/ground_truth", 0) >= 10
