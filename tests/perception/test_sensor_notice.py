"""--lidar/--stereo say what they add and where its data go; `snakesim check` takes them too."""

import pytest


@pytest.fixture
def cli():
    from click.testing import CliRunner

    from snakesim.framework.cli import cli, install_plugin_cli

    install_plugin_cli()
    return lambda *args: CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


def _resolved():
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry

    reg = default_registry()
    return resolve(reg.default_assembly(), search_path=reg.assembly_paths(),
                   overrides=["robot.modules=2"])


def test_notice_names_resolution_rate_frame_and_destination():
    from snakesim.components.perception.attach import attach_lidar, attach_stereo, sensor_notice

    r = _resolved()
    attach_lidar(r, "spinning-32")
    attach_stereo(r, "64x48")
    assert sensor_notice(r, "lidar") == ("sensor lidar (lidar): spinning-32, 32 channels x 1024 beams, 10 Hz, "
                                         "frame 'lidar'; not published: add --viz or --ros2")
    line = sensor_notice(r, "stereo", ["viz", "ros2"])
    assert "64x48 px" in line and "5 Hz" in line and "frame 'camera_left'" in line
    assert "drawn by --viz; published on ROS 2 (--ros2)" in line and "not published" not in line
    r.record.append(("lidar.returns", None))
    assert sensor_notice(r, "lidar").endswith("recorded: lidar.returns")


def test_check_takes_lidar_and_stereo(cli):
    res = cli("check", "--set", "robot.modules=2", "--lidar", "spinning-32", "--stereo", "64x48")
    assert res.exit_code == 0, res.output
    assert "sensor lidar (lidar): spinning-32" in res.stderr and "not published: add --viz or --ros2" in res.stderr
    assert "sensor stereo (stereo_camera): 64x48 px" in res.stderr
    assert "stereo_camera" in res.stdout         # built: listed among the components


def test_run_with_viz_says_where_the_sensor_goes(cli, tmp_path):
    out = tmp_path / "s.rrd"
    res = cli("run", "--set", "robot.modules=2", "--duration", "0.04", "--quiet", "--lidar", "spinning-32",
              "--viz", "save", out)
    assert res.exit_code == 0, res.output
    assert "sensor lidar (lidar): spinning-32, 32 channels x 1024 beams, 10 Hz, frame 'lidar'; drawn by --viz" \
        in res.stderr
