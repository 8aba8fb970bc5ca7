"""--ros2-mcap on a full disk (components/ros2/mcap_recorder.py): a clear error naming the file and the cause,
a non-zero exit, the partial recording kept as FILE.partial (FILE is not left corrupt) and recoverable.

The disk fills as tests/framework's output-file tests make it: ``output_files._write_all``, the one write of
every output file, raises ENOSPC from the Nth write of the MCAP file on (any file system, no tmpfs needed).
"""

from __future__ import annotations

import errno
import json
import time

import pytest
from click.testing import CliRunner

from snakesim.framework import output_files

pytest.importorskip("mcap")

CLOCK = "rosgraph_msgs/msg/Clock"
NOSPACE = "No space left on device"


def _fill_disk_after(monkeypatch, writes: int) -> list[int]:
    """Writes to a .mcap file succeed ``writes`` times, then the disk is full; the sizes tried, returned."""
    tried: list[int] = []
    write = output_files._write_all

    def full(fh, data):
        if str(getattr(fh, "name", "")).endswith(".mcap"):
            tried.append(len(data))
            if len(tried) > writes:
                raise OSError(errno.ENOSPC, NOSPACE)
        write(fh, data)

    monkeypatch.setattr(output_files, "_write_all", full)
    return tried


def _clock(i: int) -> bytes:
    return b"\0\1\0\0" + i.to_bytes(8, "little")


def test_a_full_disk_mid_run_is_an_error_once_and_the_partial_file_recovers(tmp_path, monkeypatch):
    """Small chunks: the disk fills at the third chunk. The add that met it raises, naming the file and the
    cause; the rest of the run (adds, close) stays quiet; the two whole chunks before it are recovered."""
    from snakesim.components.ros2.mcap_recorder import McapFile, McapWriteError
    from snakesim.components.ros2.mcap_recover import recover

    path = tmp_path / "run.mcap"
    f = McapFile(path, chunk_size=200, flush_period=60.0)
    cid = f.channel("/clock", CLOCK)
    tried = _fill_disk_after(monkeypatch, 4)          # a chunk is two writes (chunk, message index)
    raised = []
    for i in range(200):
        try:
            f.add(cid, i, _clock(i))
        except McapWriteError as e:
            raised.append((i, str(e)))
    f.close()                                         # told already: no second error
    assert len(raised) == 1 and len(tried) == 5, (raised, tried)
    kept = tmp_path / "run.mcap.partial"
    msg = raised[0][1]
    assert str(path) in msg and NOSPACE in msg and str(kept) in msg and "snakesim mcap recover" in msg, msg
    assert not path.exists() and kept.exists()
    monkeypatch.undo()
    r = recover(kept, tmp_path / "recovered.mcap")
    # every message added before the failing chunk was finished: two chunks of 200 B, ~15 messages each
    assert 0 < r.messages < raised[0][0] and not r.complete


def test_a_full_disk_met_by_the_flusher_is_raised_by_close(tmp_path, monkeypatch):
    """A held run: the flusher thread's timed write fails; nothing is raised in that thread, the run's close
    raises it."""
    from snakesim.components.ros2.mcap_recorder import McapFile, McapWriteError

    f = McapFile(tmp_path / "held.mcap", flush_period=0.05)
    cid = f.channel("/clock", CLOCK)
    _fill_disk_after(monkeypatch, 0)
    f.add(cid, 1, _clock(1))
    deadline = time.monotonic() + 5.0
    while f.error is None and time.monotonic() < deadline:
        time.sleep(0.02)
    assert f.error is not None and f.flushes == 0
    with pytest.raises(McapWriteError, match=NOSPACE):
        f.close()


def test_a_folder_that_cannot_hold_the_file_is_named(tmp_path):
    from snakesim.components.ros2.mcap_recorder import McapFile, McapWriteError

    (tmp_path / "plain").write_text("a file, not a folder")
    with pytest.raises(McapWriteError, match="cannot write .*plain/run.mcap"):
        McapFile(tmp_path / "plain" / "run.mcap")


def test_run_with_ros2_mcap_on_a_full_disk_exits_non_zero_naming_the_file(dds_domain, tmp_path, monkeypatch):
    """The whole command: the disk fills when the run's last chunk and summary are written."""
    from snakesim.framework.cli import cli, install_plugin_cli

    path = tmp_path / "run.mcap"
    tried = _fill_disk_after(monkeypatch, 3)          # magic, header, an empty flush: the start only
    install_plugin_cli()
    res = CliRunner().invoke(cli, ["run", "pendulum", "--duration", "0.2", "--quiet", "--ros2-domain",
                                   str(dds_domain()), "--ros2-mcap", str(path), "--out", str(tmp_path / "out")])
    assert res.exit_code == 1 and len(tried) == 4, (res.exit_code, tried, res.output)
    assert f"cannot write {path}: {NOSPACE}" in res.output and "Traceback" not in res.output, res.output
    assert not path.exists() and (tmp_path / "run.mcap.partial").exists()
    # the run folder says how it ended (a failure naming the error), not "incomplete" as a killed run's does
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["outcome"] == "failure" and summary["completed"] is False, summary
    assert NOSPACE in summary["error"] and str(path) in summary["error"], summary
