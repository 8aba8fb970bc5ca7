"""A separate process beside a `snakesim run --ros2`: the tests' peers (subscriber.py, commander.py,
graph_listener.py, sensor_subscriber.py, sim_client.py) print {"ready": true} once their readers and writers
are up, and one JSON line of what they saw, last, when they exit."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).parent
SNAKESIM = Path(sys.executable).with_name("snakesim")


def peer_env() -> dict:
    """Unbuffered output, and Cyclone's default (loopback-capable) configuration rather than the shell's."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("CYCLONEDDS_URI", None)
    return env


def start_peer(script: str, *args, env: dict | None = None) -> subprocess.Popen:
    """Start tests/ros2/<script> with args and wait until it says it is ready (killed if it does not)."""
    proc = subprocess.Popen([sys.executable, str(HERE / script), *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env or peer_env())
    line = proc.stdout.readline()
    if not line or json.loads(line) != {"ready": True}:
        proc.kill()
        _, err = proc.communicate()
        raise AssertionError(f"{script} did not get ready: {line!r}\n{err}")
    return proc


def peer_result(proc: subprocess.Popen, timeout: float, check: bool = False) -> dict:
    """The peer's last JSON line once it exits (killed if it outlives timeout); ``check``: it must exit 0."""
    try:
        out, err = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    if check:
        assert proc.returncode == 0, err[-3000:]
    return json.loads(out.strip().splitlines()[-1])


def run_beside(peer: tuple, run_args: list, *, timeout: float, peer_timeout: float):
    """`snakesim run *run_args` beside the peer (script, *args), which must get ready first; the run must
    exit 0. Returns (what the peer saw, the run's CompletedProcess)."""
    env = peer_env()
    proc = start_peer(*peer, env=env)
    try:
        run = subprocess.run([str(SNAKESIM), "run", *map(str, run_args)], capture_output=True, text=True,
                             timeout=timeout, env=env)
        assert run.returncode == 0, run.stderr[-3000:]
    except BaseException:
        proc.kill()
        proc.wait()
        raise
    return peer_result(proc, peer_timeout), run
