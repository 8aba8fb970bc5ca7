"""docs/ros2.md (the README's former "Drive it from ROS 2" section): its node example runs, as written, against the `snakesim run` it names,
with the CYCLONEDDS_URI it gives."""

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

PAGE = Path(__file__).resolve().parents[2] / "docs" / "ros2.md"


def _section() -> str:
    return PAGE.read_text()


def test_the_ros2_node_example_runs_against_snakesim(tmp_path):
    pytest.importorskip("cyclonedds.domain")
    sec = _section()
    console = re.search(r"```console\n(.*?)```", sec, re.S).group(1)
    node = re.search(r"```python\n(.*?)```", sec, re.S).group(1)
    assert node.startswith("# ros2_node.py")
    uri = re.search(r"export CYCLONEDDS_URI='([^']+)'", console).group(1)
    run = next(ln for ln in console.splitlines() if ln.startswith("$ snakesim run"))
    argv = shlex.split(run[2:].rstrip(" &"))
    (tmp_path / "ros2_node.py").write_text(node)
    domain = 220 + os.getpid() % 13           # outside tests/ros2's domains (1-219)
    env = {**os.environ, "CYCLONEDDS_URI": uri, "ROS_DOMAIN_ID": str(domain), "PYTHONUNBUFFERED": "1"}
    exe = Path(sys.executable).with_name("snakesim")
    sim = subprocess.Popen([str(exe), *argv[1:], "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True, env=env)
    try:
        out = subprocess.run([sys.executable, "ros2_node.py"], cwd=tmp_path, env=env, capture_output=True,
                             text=True, timeout=120)
    finally:
        sim.kill()
        _, err = sim.communicate()
    assert out.returncode == 0, f"{out.stdout[-2000:]}\n{out.stderr[-2000:]}\nsnakesim: {err[-2000:]}"
    assert out.stdout.strip().endswith("reached") and "bend_01" in out.stdout
