"""`snakesim run --ros2` seen from a separate process that knows only cyclonedds and the standard types."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).parent
RATE = 50.0           # Hz, /joint_states and /clock as set on the command line
DURATION = 1.0        # s simulated


def test_joint_states_at_the_set_rate_and_clock_advancing(dds_domain):
    from snakesim.components.multibody.robot_model import RobotModel

    domain = dds_domain()
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("CYCLONEDDS_URI", None)
    sub = subprocess.Popen([sys.executable, str(HERE / "subscriber.py"), str(domain), "40"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert json.loads(sub.stdout.readline()) == {"ready": True}, sub.stderr.read()
        exe = Path(sys.executable).with_name("snakesim")
        run = subprocess.run([str(exe), "run", "robot-zero-g", "--set", "robot.modules=3", "--duration", str(DURATION),
                              "--ros2-domain", str(domain), "--ros2-rate", f"joint_states={RATE:g}",
                              "--ros2-rate", f"clock={RATE:g}", "--quiet"],
                             capture_output=True, text=True, timeout=60, env=env)
        assert run.returncode == 0, run.stderr
        out, err = sub.communicate(timeout=30)
    finally:
        if sub.poll() is None:
            sub.kill()
            sub.wait()
    got = json.loads(out.strip().splitlines()[-1])
    robot = RobotModel.load(design="eels-1.0", modules=3)
    assert got["names"] == list(robot.joints) and len(got["position_sample"]) == robot.nj
    stamps = got["joint_states"]
    expected = int(DURATION * RATE)
    assert len(stamps) >= 0.8 * expected, f"{len(stamps)} of ~{expected} /joint_states received"
    gaps = {round(b - a, 6) for a, b in zip(stamps, stamps[1:])}
    assert gaps == {round(1 / RATE, 6)}, f"stamps not {1 / RATE} s apart: {sorted(gaps)}"
    clock = got["clock"]
    assert len(clock) >= 0.8 * expected and all(b > a for a, b in zip(clock, clock[1:]))
    assert clock[-1] >= DURATION - 2 / RATE
    assert got["tf_count"] > 0 and got["tf_frames"][0][0] == "world"
    assert got["description_chars"] == len(robot.urdf)
