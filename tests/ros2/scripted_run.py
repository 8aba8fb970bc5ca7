"""One `snakesim run` beside a scripted ROS 2 client (sim_client.py or gait_client.py, a separate process on
loopback): the command tests' shared scaffolding. The client is started first and waits for /clock; the run
must end cleanly, every client step must have gone out, and each expected rejection must be in the run's log."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent


def parameter(name: str, value: float, typ: int = 3):
    """An rcl_interfaces/Parameter with a double (type 3) or integer (type 2) value."""
    from snakesim.components.ros2.messages import ros_type

    P, V = ros_type("rcl_interfaces/msg/Parameter"), ros_type("rcl_interfaces/msg/ParameterValue")
    return P(name=name, value=V(type=typ, double_value=value) if typ == 3 else V(type=typ, integer_value=int(value)))


def run_with_client(domain: int, out: Path, run_args: list[str], script: list[dict], *, client: str = "sim_client.py",
                    rejections=(), client_seconds: float = 90.0, timeout: float = 240.0):
    """Run ``snakesim run *run_args`` on ``domain`` with ``--out out`` while ``client`` plays ``script``.
    Returns (the client's report: its last JSON line, the recorded signals as a named array)."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("CYCLONEDDS_URI", None)
    proc = subprocess.Popen([sys.executable, str(HERE / client), str(domain), str(client_seconds), json.dumps(script)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert json.loads(proc.stdout.readline()) == {"ready": True}, proc.stderr.read()
        exe = Path(sys.executable).with_name("snakesim")
        run = subprocess.run([str(exe), "run", *run_args, "--ros2-domain", str(domain), "--quiet", "--out", str(out)],
                             capture_output=True, text=True, timeout=timeout, env=env)
        stdout, _ = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert run.returncode == 0, run.stderr[-3000:]
    got = json.loads(stdout.strip().splitlines()[-1])
    assert all("error" not in s for s in got["steps"]), got["steps"]
    for reason in rejections:
        assert reason in run.stderr, f"no rejection '{reason}' in the run's log:\n{run.stderr[-3000:]}"
    return got, np.genfromtxt(out / "signals.csv", delimiter=",", names=True)
