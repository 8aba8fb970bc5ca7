"""One rule for paths in assemblies: relative to the file that names them, from any working folder."""

from __future__ import annotations

from click.testing import CliRunner

from snakesim.framework.cli import cli, install_plugin_cli
from snakesim.framework.session import load_session

SCENE = """
sim: {duration: 0.01, dt: 0.001}
parameters:
  robot: {urdf: robots/two.urdf}
components:
  robot:
    type: multibody
    params: {design: eels-1.0, modules: 2, urdf: "${robot.urdf}", gravity: [0, 0, 0]}
record: [robot.joint_q]
"""


def _scene(tmp_path):
    install_plugin_cli()
    folder = tmp_path / "scenes"
    res = CliRunner().invoke(cli, ["robot", "urdf", "--robot", "eels-1.0", "--modules", "2",
                                   "-o", str(folder / "robots" / "two.urdf")])
    assert res.exit_code == 0, res.output
    (folder / "scene.yaml").write_text(SCENE)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    return folder, elsewhere


def test_a_urdf_named_in_a_scene_is_relative_to_the_scene(tmp_path, monkeypatch):
    folder, elsewhere = _scene(tmp_path)
    monkeypatch.chdir(elsewhere)
    session = load_session(str(folder / "scene.yaml"))
    assert session.plan.components["robot"].p.urdf == str(folder / "robots" / "two.urdf")
    res = CliRunner().invoke(cli, ["run", str(folder / "scene.yaml"), "--quiet", "--out", "out"])
    assert res.exit_code == 0, res.output
    # the saved configuration holds the absolute path: it runs again from anywhere
    assert str(folder / "robots" / "two.urdf") in (elsewhere / "out" / "config.yaml").read_text()


def test_a_path_on_the_command_line_is_relative_to_the_working_folder(tmp_path, monkeypatch):
    folder, _ = _scene(tmp_path)
    monkeypatch.chdir(folder / "robots")
    session = load_session(str(folder / "scene.yaml"), overrides=["robot.urdf=two.urdf"])
    assert session.plan.components["robot"].p.urdf == str(folder / "robots" / "two.urdf")
