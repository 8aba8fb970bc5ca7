"""What keeping a ``--ros2-mcap`` recording recoverable costs: small chunks written unbuffered, and a chunk
flushed at most ``flush_period`` wall seconds after its first message (:class:`McapFile`).

Replays a recording's own messages (their topics, sizes and bytes, so compression is realistic: by default a
10 s robot-zero-g run's robot topics, recorded first) through the recorder's writer, ``--copies``
times back to back with shifted log times, under:

    plain        mcap's Writer on a buffered file, 1 MiB chunks, no timed flush (no lock, no thread): what
                 the recorder did before
    default      McapFile as a run uses it: 256 KiB chunks, unbuffered, flush period 1 s (the replay is
                 faster than that: chunks are written as they fill)
    flush /50    McapFile, a flush (what the timer does: the chunk in progress finished, compressed and
                 written) every 50 messages
    flush /10    the same, every 10 messages

each best of ``--repeats``, alternately. Prints µs per message, the file's size and the flushes; from the
forced-flush rows, the cost of one flush (their extra time over ``default`` per flush) and what one flush a
second costs in % of a core.

    python bench/mcap_flush.py [--source FILE.mcap] [--copies 20] [--repeats 5] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _messages(path: Path):
    """[(topic, schema name, schema text, log time, bytes)] of a recording, in file order."""
    from mcap.reader import make_reader

    out = []
    with open(path, "rb") as f:
        for schema, channel, msg in make_reader(f).iter_messages(log_time_order=False):
            out.append((channel.topic, schema.name, msg.log_time, msg.data))
    return out


def _record_source(tmp: Path) -> Path:
    path = tmp / "source.mcap"
    exe = Path(sys.executable).with_name("snakesim")
    subprocess.run([str(exe), "run", "robot-zero-g", "--set", "robot.modules=3", "--duration", "10",
                    "--ros2-mcap", str(path), "--quiet"], check=True,
                   stdout=subprocess.DEVNULL)
    return path


def _plain(path: Path, msgs, copies: int, span: int) -> tuple[float, int, int]:
    from mcap.writer import CompressionType, Writer

    from snakesim.components.ros2.mcap_recorder import PROFILE, schema_text

    t0 = time.perf_counter()
    with open(path, "wb") as stream:
        w = Writer(stream, chunk_size=1 << 20, compression=CompressionType.ZSTD)
        w.start(profile=PROFILE, library="bench")
        schemas, channels = {}, {}
        for k in range(copies):
            for topic, ros_name, log_time, data in msgs:
                cid = channels.get(topic)
                if cid is None:
                    sid = schemas.get(ros_name)
                    if sid is None:
                        sid = schemas[ros_name] = w.register_schema(ros_name, "ros2msg",
                                                                    schema_text(ros_name).encode())
                    cid = channels[topic] = w.register_channel(topic, "cdr", sid)
                t = log_time + k * span
                w.add_message(cid, log_time=t, data=data, publish_time=t)
        w.finish()
    return time.perf_counter() - t0, path.stat().st_size, 0


def _mcap_file(path: Path, msgs, copies: int, span: int, every: int = 0) -> tuple[float, int, int]:
    from snakesim.components.ros2.mcap_recorder import CHUNK_SIZE, McapFile

    t0 = time.perf_counter()
    f = McapFile(path, CHUNK_SIZE, 1.0)
    channels = {}
    i = 0
    for k in range(copies):
        for topic, ros_name, log_time, data in msgs:
            cid = channels.get(topic)
            if cid is None:
                cid = channels[topic] = f.channel(topic, ros_name)
            f.add(cid, log_time + k * span, data)
            i += 1
            if every and i % every == 0:
                f.flush()
    flushes = f.flushes
    f.close()
    return time.perf_counter() - t0, path.stat().st_size, flushes


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--source", type=Path, default=None, help="a recording to replay (default: record one)")
    ap.add_argument("--copies", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        src = a.source or _record_source(tmp)
        msgs = _messages(src)
        span = max(m[2] for m in msgs) + 1
        n = len(msgs) * a.copies
        cases = {"plain": lambda p: _plain(p, msgs, a.copies, span),
                 "default": lambda p: _mcap_file(p, msgs, a.copies, span),
                 "flush /50": lambda p: _mcap_file(p, msgs, a.copies, span, 50),
                 "flush /10": lambda p: _mcap_file(p, msgs, a.copies, span, 10)}
        best: dict[str, tuple] = {}
        for _ in range(a.repeats):
            for name, run in cases.items():
                r = run(tmp / "out.mcap")
                if name not in best or r[0] < best[name][0]:
                    best[name] = r
        raw = sum(len(m[3]) for m in msgs) * a.copies
        print(f"{n} messages ({raw / 1e6:.1f} MB of CDR) from {src.name if a.source else 'a 10 s robot-zero-g run'}, "
              f"best of {a.repeats}")
        print(f"{'case':<12} {'us/msg':>8} {'MB':>8} {'flushes':>8}")
        for name, (t, size, flushes) in best.items():
            print(f"{name:<12} {1e6 * t / n:8.2f} {size / 1e6:8.2f} {flushes:8d}")
        per_flush = []
        for name in ("flush /50", "flush /10"):
            t, _size, flushes = best[name]
            if flushes:
                per_flush.append((t - best["default"][0]) / flushes)
        cost = max(max(per_flush), 0.0) if per_flush else float("nan")
        print(f"one timed flush: {1e6 * cost:.0f} us  ->  at one a second: {100 * cost:.3f} % of a core")
        if a.json:
            a.json.write_text(json.dumps({"messages": n, "cdr_bytes": raw, "cases": {
                k: {"us_per_message": 1e6 * v[0] / n, "bytes": v[1], "flushes": v[2]} for k, v in best.items()},
                "flush_us": 1e6 * cost, "cpu_percent_at_1hz": 100 * cost, "cpus": os.cpu_count()}, indent=1))


if __name__ == "__main__":
    main()
