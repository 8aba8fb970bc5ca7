"""--ros2-mcap in every flag combination, and a killed run's file made readable again.

Whatever is on the wire is in the MCAP: the run options applied as the command line applies them (in its
order), the file read back with the standard ``mcap`` reader, every channel's messages decoded with
mcap-ros2-support and, independently, rosbags' CDR codec, every channel with its offered_qos_profiles.
A run killed with SIGKILL leaves a file the standard reader refuses; ``snakesim mcap recover`` rewrites
it readable, as it does any file cut at an arbitrary byte; bad input is refused naming the file."""

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

pytest.importorskip("mcap")
pytest.importorskip("mcap_ros2")

ROBOT = {"/clock": "rosgraph_msgs/msg/Clock", "/joint_states": "sensor_msgs/msg/JointState",
         "/tf": "tf2_msgs/msg/TFMessage", "/robot_description": "std_msgs/msg/String",
         "/tf_static": "tf2_msgs/msg/TFMessage", "/sim/real_time_factor": "std_msgs/msg/Float64"}
LIDAR = {"/lidar/points": "sensor_msgs/msg/PointCloud2"}
STEREO = {f"/stereo/{side}/{what}": typ for side in ("left", "right")
          for what, typ in (("image_raw", "sensor_msgs/msg/Image"), ("depth", "sensor_msgs/msg/Image"),
                            ("labels", "sensor_msgs/msg/Image"), ("camera_info", "sensor_msgs/msg/CameraInfo"))}
#: topic -> (reliable, depth, transient local) as offered on the wire
WIRE_QOS = {"/clock": (False, 1, False), "/tf": (True, 100, False), "/tf_static": (True, 1, True),
            "/robot_description": (True, 1, True), "/joint_states": (True, 10, False),
            "/sim/real_time_factor": (True, 10, False), **{t: (True, 5, False) for t in {**LIDAR, **STEREO}}}

SNAKESIM = Path(sys.executable).with_name("snakesim")


def _read(path):
    """topic -> (schema name, channel metadata, [(log time, decoded, rosbags-decoded)]) with the standard reader."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    from snakesim.components.ros2.messages import typestore

    ts = typestore()
    out = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for ch in reader.get_summary().channels.values():
            schema = reader.get_summary().schemas[ch.schema_id]
            out[ch.topic] = (schema.name, dict(ch.metadata), [])
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            assert channel.message_encoding == "cdr" and schema.encoding == "ros2msg"
            independent = ts.deserialize_cdr(message.data, schema.name)
            out[channel.topic][2].append((message.log_time, decoded, independent))
    return out


def _session(extras: list, duration=0.25):
    """The run as `snakesim run robot-zero-g --set robot.modules=2 --duration D <extras in this order>` builds it."""
    from snakesim.framework.cli import _session as cli_session, install_plugin_cli

    install_plugin_cli()
    return cli_session("robot-zero-g", (), ("robot.modules=2",), dict(extras), duration=duration, dt=None,
                       integrator=None, realtime=None)


def _close_recordings(s):
    for name, comp in s.plan.components.items():
        if comp.type_name in ("ros2_mcap", "ros2_sensor_mcap", "ros2_publisher", "ros2_sensor_bridge"):
            s.plan.caches[name].close()


MATRIX = {
    "--ros2-mcap": ([], ROBOT),
    "--ros2-mcap --lidar --stereo": ([("lidar", "spinning-32"), ("stereo", "32x24")], {**ROBOT, **LIDAR, **STEREO}),
    "--ros2 --ros2-mcap --lidar": ([("ros2", True), ("lidar", "spinning-32")], {**ROBOT, **LIDAR}),
    "--lidar --ros2-mcap --ros2 --ros2-rate": ([("lidar", "spinning-32"), ("ros2", True), ("ros2_rate", ("tf=10",))],
                                               {**ROBOT, **LIDAR}),
}


@pytest.mark.parametrize("flags", list(MATRIX))
def test_the_mcap_holds_what_the_wire_carries_in_every_flag_combination(flags, dds_domain, tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_DOMAIN_ID", str(dds_domain()))
    extras, want = MATRIX[flags]
    path = tmp_path / "run.mcap"
    order = flags.split()
    extras = sorted([("ros2_mcap", str(path)), *extras],
                    key=lambda kv: order.index("--" + kv[0].replace("_", "-")))
    s = _session(extras)
    types = {c.type_name for c in s.plan.components.values()}
    # what goes on the wire: the publisher, and the sensor bridge when there are sensors
    assert "ros2_publisher" in types and ("ros2_sensor_bridge" in types) == (want != ROBOT)
    s.run()
    _close_recordings(s)
    got = _read(path)
    assert {t: v[0] for t, v in got.items()} == want
    for topic, (_schema, meta, msgs) in got.items():
        # every channel carries rosbag2's offered_qos_profiles: the QoS it has on the wire
        (q,) = yaml.safe_load(meta["offered_qos_profiles"])
        reliable, depth, latched = WIRE_QOS[topic]
        assert (q["reliability"], q["depth"], q["durability"]) == (1 if reliable else 2, depth, 1 if latched else 2), topic
        if topic != "/sim/real_time_factor":          # 1 Hz: none in a 0.25 s run
            assert msgs, topic
        times = [m[0] for m in msgs]
        assert times == sorted(times), topic
        for _t, decoded, independent in msgs:          # both decoders agree
            if hasattr(decoded, "header"):
                assert (decoded.header.frame_id, decoded.header.stamp.sec, decoded.header.stamp.nanosec) == \
                    (independent.header.frame_id, independent.header.stamp.sec, independent.header.stamp.nanosec)
    if "/lidar/points" in want:
        cloud = got["/lidar/points"][2][0][1]
        assert cloud.header.frame_id == "lidar" and cloud.width * cloud.height > 0
        assert [m[0] for m in got["/lidar/points"][2]] == [0, 100_000_000, 200_000_000]       # 10 Hz, at sample times
    if "--ros2-rate" in flags:                     # tf=10: the recorder follows the publisher's rates
        robot_tf = [t for t, m, _i in got["/tf"][2] if any(tr.child_frame_id == "module_00" for tr in m.transforms)]
        assert robot_tf == [0, 100_000_000, 200_000_000]


def test_a_held_run_has_its_chunk_on_disk_within_the_flush_period(tmp_path):
    """The flusher thread writes the chunk in progress when the run adds nothing (held, paused)."""
    from mcap.exceptions import EndOfFile
    from mcap.reader import NonSeekingReader

    from snakesim.components.ros2.mcap_recorder import McapFile

    f = McapFile(tmp_path / "held.mcap", flush_period=0.2)
    try:
        cid = f.channel("/clock", "rosgraph_msgs/msg/Clock")
        f.add(cid, 10, b"\0\1\0\0" + bytes(8))
        time.sleep(0.6)

        def messages():
            got = []
            with open(tmp_path / "held.mcap", "rb") as g:
                try:
                    got.extend(m.log_time for _s, _c, m in NonSeekingReader(g).iter_messages(log_time_order=False))
                except EndOfFile:
                    pass
            return got
        assert messages() == [10] and f.flushes == 1
    finally:
        f.close()


def _recover_cli(*args):
    from click.testing import CliRunner

    from snakesim.framework.cli import cli

    return CliRunner().invoke(cli, ["mcap", "recover", *map(str, args)])


@pytest.mark.slow
def test_a_killed_run_is_recovered_with_every_channel(dds_domain, tmp_path):
    from mcap.reader import make_reader

    path, out = tmp_path / "killed.mcap", tmp_path / "recovered.mcap"
    env = {**os.environ}
    env.pop("CYCLONEDDS_URI", None)
    proc = subprocess.Popen([str(SNAKESIM), "run", "robot-zero-g", "--set", "robot.modules=2", "--duration", "600",
                             "--ros2-mcap", str(path), "--lidar", "spinning-32", "--ros2-domain", str(dds_domain()),
                             "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and (not path.exists() or path.stat().st_size < 20_000):
            assert proc.poll() is None, proc.stderr.read().decode()
            time.sleep(0.2)
        time.sleep(2.0)
        assert proc.poll() is None, "the run ended before it could be killed"
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    # the standard reader refuses a file without its footer ...
    with open(path, "rb") as f, pytest.raises(Exception):
        list(make_reader(f).iter_messages())
    # ... `snakesim mcap recover` rewrites it readable, and says what it recovered per channel
    r = subprocess.run([str(SNAKESIM), "mcap", "recover", str(path), "-o", str(out)], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    got = _read(out)
    assert set(got) == {*ROBOT, *LIDAR}
    counts = {t: len(v[2]) for t, v in got.items()}
    assert counts["/joint_states"] > 10 and counts["/clock"] >= counts["/joint_states"] and counts["/lidar/points"] >= 2
    for topic, n in counts.items():
        assert any(line.split() == [topic, str(n)] for line in r.stdout.splitlines()), (topic, r.stdout)
    for topic in ("/clock", "/joint_states", "/lidar/points", "/tf"):
        times = [m[0] for m in got[topic][2]]
        assert all(b > a for a, b in zip(times, times[1:])), topic                   # monotonically increasing
    clock = [m[1].clock.sec * 10**9 + m[1].clock.nanosec for m in got["/clock"][2]]
    assert clock == [m[0] for m in got["/clock"][2]]
    with open(out, "rb") as f:                       # in log-time order, as any reader reads it
        summary = make_reader(f).get_summary()
        f.seek(0)
        times = [m.log_time for _s, _c, m in make_reader(f).iter_messages()]
    assert times == sorted(times) and summary.statistics.message_count == sum(counts.values())


def test_a_file_cut_at_any_byte_is_recovered_up_to_its_last_whole_chunk(dds_domain, tmp_path, monkeypatch):
    from mcap.reader import make_reader

    from snakesim.components.ros2.mcap_recover import recover

    monkeypatch.setenv("ROS_DOMAIN_ID", str(dds_domain()))
    path = tmp_path / "whole.mcap"
    from snakesim.components.ros2.mcap_recorder import attach_mcap
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry
    from snakesim.framework.session import Session

    reg = default_registry()
    resolved = resolve("robot-zero-g", search_path=reg.assembly_paths(), overrides=["robot.modules=2"],
                       sim_overrides={"duration": 0.6})
    rec = attach_mcap(resolved, str(path))
    resolved.components[rec].params["chunk_size"] = 4096         # several small chunks
    s = Session(resolved, reg)
    s.run()
    _close_recordings(s)
    with open(path, "rb") as f:
        assert make_reader(f).get_summary().statistics.chunk_count > 5

    def messages(p):
        with open(p, "rb") as f:
            return [(c.topic, m.log_time, m.data) for _s, c, m in make_reader(f).iter_messages(log_time_order=False)]
    whole, data = messages(path), path.read_bytes()
    rng = random.Random(26)
    last = -1
    for cut in sorted({60, len(data) // 2, len(data) - 1, len(data), *(rng.randrange(60, len(data)) for _ in range(12))}):
        p = tmp_path / "cut.mcap"
        p.write_bytes(data[:cut])
        r = recover(p, tmp_path / "out.mcap")
        got = messages(tmp_path / "out.mcap")
        assert got == whole[:len(got)] and len(got) == r.messages >= last        # a prefix, growing with the cut
        last = len(got)
        assert r.complete == (cut == len(data))
    assert last == len(whole) > 50


def test_bad_input_to_recover_is_refused_naming_the_file(tmp_path):
    empty, text, cut = tmp_path / "empty.mcap", tmp_path / "notes.mcap", tmp_path / "header.mcap"
    empty.write_bytes(b"")
    text.write_text("not an mcap\n" * 10)
    cut.write_bytes(b"\x89MCAP0\r\n\x01\x20")                   # the magic and half a header record
    for p, says in ((tmp_path / "missing.mcap", "no such file"), (empty, "empty file"),
                    (text, "not an MCAP file"), (cut, "cut short in its header"), (tmp_path, "not a file")):
        r = _recover_cli(p)
        assert r.exit_code != 0 and str(p) in r.output and says in r.output, r.output
    good = tmp_path / "good.mcap"
    from snakesim.components.ros2.mcap_recorder import McapFile

    f = McapFile(good)
    f.add(f.channel("/clock", "rosgraph_msgs/msg/Clock"), 0, b"\0\1\0\0" + bytes(8))
    f.close()
    r = _recover_cli(good, "-o", good)                         # never over its input
    assert r.exit_code != 0 and "replace the input" in r.output
    r = _recover_cli(good)
    assert r.exit_code == 0 and (tmp_path / "good.recovered.mcap").exists() and "complete" in r.output
