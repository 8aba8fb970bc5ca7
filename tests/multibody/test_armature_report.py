"""Armature is visible: where each joint's value comes from, in `snakesim check` and the design."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from snakesim.components.multibody.joint_values import armature_sources
from snakesim.components.multibody.component import MultibodyParams
from snakesim.components.multibody import RobotModel
from snakesim.framework.cli import cli, install_plugin_cli
from snakesim.robots.designs import get_design


def _sources(**params):
    robot = RobotModel.load(design="eels-1.0", modules=2)
    return robot, armature_sources(robot, MultibodyParams(design="eels-1.0", modules=2, **params))


def test_design_default_is_the_designs_per_kind_table_times_effort():
    robot, src = _sources()
    table = get_design("eels-1.0").armature_per_effort
    for joint, (value, origin) in src.items():
        kind = joint.split("_")[0]
        assert value == pytest.approx(table[kind] * robot.tree.joint_by_name[joint].effort)
        assert origin.startswith("design eels-1.0")


def test_assembly_settings_win_and_say_so():
    _, src = _sources(armature={"bend_01": 0.0}, armature_per_effort={"twist": 1e-3})
    assert src["bend_01"] == (0.0, "assembly: armature")
    assert src["twist_00"][1].startswith("assembly: armature_per_effort")
    assert src["bend_00"][1].startswith("design eels-1.0")


def test_check_prints_each_kind_with_its_source():
    install_plugin_cli()
    res = CliRunner().invoke(cli, ["check", "robot-zero-g", "--modules", "2", "--set",
                                   "components.robot.params.armature={screw_*: 0.0}"])
    assert res.exit_code == 0, res.output
    lines = [ln for ln in res.output.splitlines() if "kg·m²" in ln and "joint(s)" in ln]
    assert any(ln.split()[0] == "bend" and "design eels-1.0" in ln for ln in lines), lines
    assert any(ln.split()[0] == "screw" and "assembly: armature" in ln for ln in lines), lines
    res = CliRunner().invoke(cli, ["check", "robot-zero-g", "--modules", "2", "--json"])
    armature = json.loads(res.output)["component_reports"]["robot"]["armature"]
    assert set(armature) == set(RobotModel.load(design="eels-1.0", modules=2).joints)
