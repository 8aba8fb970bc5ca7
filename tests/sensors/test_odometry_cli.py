"""``snakesim run --odometry [LINK]``: the odometry component on the default scene, wired to the robot, its
truth and estimate recorded (the truth is the recorded link pose); a bad link is a clear error naming it and
the valid ones; ``snakesim check`` takes the option; with ``--ros2-mcap`` the file has /odom and
/odom/ground_truth (the option is applied before the ROS 2 sinks, which wire what they find)."""

from __future__ import annotations

import csv

import numpy as np
import pytest
from click.testing import CliRunner

from snakesim.framework.cli import cli, install_plugin_cli

POSE = ("x", "y", "z", "qx", "qy", "qz", "qw")


def _invoke(*args, catch=False):
    install_plugin_cli()
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=catch)


def _columns(path):
    with open(path) as fh:
        rows = list(csv.reader(fh))
    head = rows[0]
    data = np.array([[float(v) for v in r] for r in rows[1:]])
    return {name: data[:, i] for i, name in enumerate(head)}


def test_run_records_odometry_and_the_truth_is_the_recorded_root_pose(tmp_path):
    out = tmp_path / "run"
    r = _invoke("run", "--odometry", "--duration", 1, "--out", out, "--quiet")
    assert r.exit_code == 0, r.output
    cols = _columns(out / "signals.csv")
    for port, names in (("pose", POSE), ("twist", ("vx", "vy", "vz", "wx", "wy", "wz")),
                        ("estimate_pose", POSE), ("estimate_twist", ("vx", "vy", "vz", "wx", "wy", "wz"))):
        assert all(f"odometry.{port}.{n}" in cols for n in names), port
    assert cols["t"][-1] == pytest.approx(1.0)
    # default link: the robot's root (the default scene's EELS: 'tail'), sampled at 50 Hz like the recording
    truth = np.stack([cols[f"odometry.pose.{n}"] for n in POSE], axis=1)
    link = np.stack([cols[f"robot.link_poses.tail.{n}"] for n in POSE], axis=1)
    np.testing.assert_allclose(truth, link, rtol=0, atol=1e-9)
    assert np.ptp(link[:, 0]) > 0 or np.ptp(link[:, 1]) > 0          # the robot moved: a real comparison
    est = np.stack([cols[f"odometry.estimate_pose.{n}"] for n in POSE], axis=1)
    np.testing.assert_allclose(est[0], truth[0], atol=1e-12)      # the estimate starts at the truth


def test_a_named_link_and_check():
    r = _invoke("check", "--odometry", "module_02", "--json")
    assert r.exit_code == 0, r.output
    assert "odometry" in r.stdout


@pytest.mark.parametrize("command", ["run", "check"])
def test_an_unknown_link_is_a_clear_error(command):
    args = [command, "--odometry", "nope"] + (["--duration", 0.01, "--quiet"] if command == "run" else [])
    r = _invoke(*args, catch=True)
    assert r.exit_code != 0
    msg = r.output
    assert "--odometry" in msg and "'nope'" in msg and "valid:" in msg and "tail" in msg and "module_02" in msg
