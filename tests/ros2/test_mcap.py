"""--ros2-mcap: the published topics in an MCAP file with ROS 2 schemas, readable after a kill."""

import os
import signal
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import pytest

from snakesim.framework.assembly import resolve
from snakesim.framework.registry import default_registry
from snakesim.framework.session import Session

pytest.importorskip("mcap")
pytest.importorskip("mcap_ros2")

TYPES = {"/clock": "rosgraph_msgs/msg/Clock", "/joint_states": "sensor_msgs/msg/JointState",
         "/tf": "tf2_msgs/msg/TFMessage", "/robot_description": "std_msgs/msg/String",
         "/tf_static": "tf2_msgs/msg/TFMessage", "/sim/real_time_factor": "std_msgs/msg/Float64"}


def _read(path, cut_short=False):
    """topic -> [(schema name, decoded, raw bytes, log time)] with mcap's reader and mcap-ros2-support's
    decoder. ``cut_short``: a file whose writer was killed (no summary, a partial record at the end) is read
    record by record, as far as it goes."""
    from mcap.exceptions import EndOfFile
    from mcap.reader import NonSeekingReader, make_reader
    from mcap_ros2.decoder import DecoderFactory

    out = {}
    with open(path, "rb") as f:
        if cut_short:
            messages = NonSeekingReader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
                log_time_order=False)
        else:
            messages = make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages()
        try:
            for schema, channel, message, decoded in messages:
                assert channel.message_encoding == "cdr" and schema.encoding == "ros2msg"
                out.setdefault(channel.topic, []).append((schema.name, decoded, message.data, message.log_time))
        except EndOfFile:
            assert cut_short
    return out


def test_recording_decodes_with_the_published_topics_types_counts_and_bytes(dds_domain, tmp_path):
    from snakesim.components.ros2.attach import attach_ros2
    from snakesim.components.ros2.mcap_recorder import attach_mcap

    reg = default_registry()
    resolved = resolve("robot-zero-g", search_path=reg.assembly_paths(), overrides=["robot.modules=2"],
                       sim_overrides={"duration": 0.3})
    pub = attach_ros2(resolved, reg, params={"domain_id": dds_domain(),
                                             "rates": {"tf": 25.0, "real_time_factor": 20.0}})
    rec = attach_mcap(resolved, str(tmp_path / "run.mcap"))
    s = Session(resolved, reg)
    s.run()
    prun, rrun = s.plan.caches[pub], s.plan.caches[rec]
    rrun.close()
    got = _read(tmp_path / "run.mcap")
    assert {t: {m[0] for m in msgs} for t, msgs in got.items()} == {t: {ty} for t, ty in TYPES.items()}
    topics = {"clock": "/clock", "joint_states": "/joint_states", "tf": "/tf"}
    assert {topics[k]: n for k, n in prun.published.items() if k in topics} == \
        {t: len(got[t]) for t in topics.values()}
    assert len(got["/robot_description"]) == 1
    assert got["/robot_description"][0][1].data == s.plan.components[pub].description_text()     # file:// URIs
    # /tf_static: once, at the first tick, the publisher's latched message byte for byte
    assert len(got["/tf_static"]) == 1 and got["/tf_static"][0][3] == 0
    static = s.plan.components[pub].static_message(0.0)
    assert len(static.transforms) > 0
    raw = static.serialize()
    assert got["/tf_static"][0][2] == raw.ljust((len(raw) + 3) & ~3, b"\0")
    assert [tr.child_frame_id for tr in got["/tf_static"][0][1].transforms] == \
        [tr.child_frame_id for tr in static.transforms]
    # /sim/real_time_factor: as many as published (from the second 20 Hz window on), positive
    rtf = got["/sim/real_time_factor"]
    assert len(rtf) == prun.published["real_time_factor"] == 5
    assert all(m[1].data > 0 for m in rtf) and [m[3] for m in rtf] == [50_000_000 * k for k in range(1, 6)]
    # the last message of each topic: the very bytes the publisher last handed to DDS
    for key, topic in topics.items():
        assert got[topic][-1][2] == bytes(prun.templates[key][2].buf), topic
    js = got["/joint_states"]
    assert list(js[-1][1].name) == list(s.plan.components[pub].joints)
    stamps = [m[1].header.stamp.sec + 1e-9 * m[1].header.stamp.nanosec for m in js]
    assert stamps == pytest.approx([0.01 * k for k in range(len(js))])
    assert [m[3] for m in js] == [round(1e9 * t) for t in stamps]                  # log time: simulated ns
    prun.close()


@pytest.mark.slow
def test_a_killed_run_leaves_a_readable_file(dds_domain, tmp_path):
    path = tmp_path / "killed.mcap"
    exe = Path(sys.executable).with_name("snakesim")
    env = {**os.environ}
    env.pop("CYCLONEDDS_URI", None)
    proc = subprocess.Popen([str(exe), "run", "robot-zero-g", "--set", "robot.modules=3", "--duration", "600",
                             "--ros2-domain", str(dds_domain()), "--ros2-mcap", str(path),
                             "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and (not path.exists() or path.stat().st_size < 5_000):
            assert proc.poll() is None, proc.stderr.read().decode()
            time.sleep(0.2)
        time.sleep(1.5)                # a chunk or two more (flushed every second of wall time)
        assert proc.poll() is None, "the run ended before it could be killed"
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    got = _read(path, cut_short=True)
    counts = Counter({t: len(m) for t, m in got.items()})
    assert counts["/joint_states"] > 10 and counts["/clock"] >= counts["/joint_states"] and counts["/tf"] > 5
    clock = [m[1].clock.sec + 1e-9 * m[1].clock.nanosec for m in got["/clock"]]
    assert all(b > a for a, b in zip(clock, clock[1:]))


def test_ros2_mcap_without_quiet_runs_and_prints_the_ros2_table_once(tmp_path):
    """The recorder shares the publisher's tick; the start print (domain, topics) is the DDS endpoint's,
    not the file's: a run with --ros2-mcap and no --quiet completes and the table is printed once."""
    import subprocess
    import sys

    path = tmp_path / "run.mcap"
    p = subprocess.run([sys.executable, "-c", "from snakesim.framework.cli import main; main()", "run", "pendulum",
                        "--duration", "0.1", "--ros2-mcap", str(path)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    assert p.stderr.count("ROS 2: domain") == 1 and path.stat().st_size > 0
