"""--viz on the command line: headless fallback, the two-word save form, clear errors."""

import pytest

from viz_scenes import SCENE

SHORT = ["--set", "robot.modules=2", "--duration", "0.05", "--quiet"]


@pytest.mark.parametrize("env", [{"CI": "true", "DISPLAY": ":0"}, {"CI": None, "DISPLAY": None, "WAYLAND_DISPLAY": None}])
def test_headless_spawn_saves_instead(tmp_path, monkeypatch, cli_runner, read_rrd, env):
    import sys

    if not sys.platform.startswith("linux") and "CI" not in {k for k, v in env.items() if v}:
        pytest.skip("the no-$DISPLAY rule is for Linux")
    monkeypatch.chdir(tmp_path)
    res = cli_runner("run", SCENE, *SHORT, "--viz", "spawn", env=env)
    assert res.exit_code == 0, res.output
    assert "no viewer window opens; saving the recording to snakesim.rrd" in res.stderr
    assert "/world/physical/terrain" in read_rrd(tmp_path / "snakesim.rrd").entities


def test_save_takes_the_file_as_its_second_word(tmp_path, cli_runner, read_rrd):
    """`--viz save FILE.rrd` before the scene argument: FILE.rrd is not read as the scene."""
    out = tmp_path / "two-words.rrd"
    res = cli_runner("run", "--viz", "save", out, SCENE, *SHORT)
    assert res.exit_code == 0, res.output
    assert read_rrd(out).entities


@pytest.mark.parametrize("value, message", [
    ("bogus", "'bogus' is not a viewer target; valid: spawn | save FILE.rrd | serve"),
    ("save=run.txt", "'run.txt': a rerun recording file must end in .rrd"),
])
def test_bad_viz_values_are_usage_errors(cli_runner, value, message):
    res = cli_runner("run", "pendulum", "--duration", "0.01", "--viz", value)
    assert res.exit_code == 2 and "Invalid value for '--viz'" in res.output and message in res.output


def test_save_without_a_file_is_a_usage_error(cli_runner):
    res = cli_runner("run", "pendulum", "--duration", "0.01", "--viz", "save")
    assert res.exit_code == 2 and "'save' needs a file name: --viz save FILE.rrd" in res.output


def test_scene_without_a_robot_gets_plots_only(tmp_path, cli_runner, read_rrd):
    out = tmp_path / "p.rrd"
    res = cli_runner("run", "pendulum", "--duration", "0.5", "--quiet", "--viz", "save", out)
    assert res.exit_code == 0, res.output
    ents = read_rrd(out).entities
    assert "/plots/pend/theta" in ents and not any(e.startswith("/world/physical/") for e in ents)
