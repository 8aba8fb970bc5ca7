"""The robot is a launch option of any robot scene: --robot, --modules, --urdf.

DOF counts come from the topology (robots/designs.py): eels-1.0 has a bend, a
twist and one embedded counter-rotating screw pair per module (3 DOF each,
paper 2.1.4: 36 DOF at 10 modules); eels-1.5 a bend, a twist and a front
screw (3 DOF); mini-eels-1.0 a bend only (1 DOF); plus 6 for the free tail.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from snakesim.framework.cli import cli, install_plugin_cli

ROBOTS = Path(__file__).resolve().parents[2] / "robots" / "urdf"


@pytest.fixture(scope="module")
def snakesim():
    install_plugin_cli()
    runner = CliRunner()

    def invoke(*args):
        res = runner.invoke(cli, list(args))
        return res
    return invoke


def _check(snakesim, *args):
    res = snakesim("check", "robot-zero-g", "--json", *args)
    assert res.exit_code == 0, res.output
    return json.loads(res.output)


@pytest.mark.parametrize("robot, modules, dof_per_module", [
    ("eels-1.0", 10, 3), ("eels-1.0", 4, 3), ("eels-1.5", 3, 3), ("mini-eels-1.0", 7, 1),
])
def test_robot_and_module_count_are_launch_options(snakesim, robot, modules, dof_per_module):
    r = _check(snakesim, "--robot", robot, "--modules", str(modules))
    nv = 6 + dof_per_module * modules
    assert r["state_size"]["tangent"] == 2 * nv
    assert r["component_reports"]["robot"]["after"]["dof"] == nv


def test_paper_36_dof_and_the_optimisation_report(snakesim):
    rep = _check(snakesim)["component_reports"]["robot"]
    assert rep["after"]["dof"] == 36                    # paper 2.1.4
    # every URDF link still has a frame, fewer of them are bodies
    assert rep["after"]["bodies"] < rep["before"]["bodies"] == rep["before"]["links"]
    assert rep["after"]["link_frames"] == rep["before"]["links"]


def test_user_urdf_with_other_numbers_is_accepted_and_used(snakesim, tmp_path):
    text = (ROBOTS / "eels-1.0.urdf").read_text()
    masses = re.findall(r'<mass value="([0-9.eE+-]+)"', text)
    heavier = re.sub(r'<mass value="([0-9.eE+-]+)"', lambda m: f'<mass value="{2 * float(m.group(1))!r}"', text)
    user = tmp_path / "mine.urdf"
    user.write_text(heavier)
    base = tmp_path / "base"
    mine = tmp_path / "mine"
    for out, extra in ((base, ()), (mine, ("--urdf", str(user)))):
        res = snakesim("run", "robot-zero-g", "--duration", "0.01", "--quiet", "--out", str(out), *extra)
        assert res.exit_code == 0, res.output
    # kinetic energy from the same joint rates doubles with every mass doubled
    # (armature is unchanged, so strictly less than double; more than 1.5x)
    def energy(folder):
        head, row = (folder / "signals.csv").read_text().splitlines()[:2]
        cols = head.split(",")
        return float(row.split(",")[cols.index("robot.energy.kinetic")])
    assert len(masses) > 20
    assert 1.5 * energy(base) < energy(mine) < 2.0 * energy(base)


def test_user_urdf_with_another_structure_lists_every_difference(snakesim, tmp_path):
    text = (ROBOTS / "eels-1.0.urdf").read_text()
    text = text.replace('name="module_09"', 'name="segment_09"').replace('link="module_09"', 'link="segment_09"')
    text = re.sub(r'(<joint name="bend_04" type=")revolute(")', r"\1prismatic\2", text)
    user = tmp_path / "odd.urdf"
    user.write_text(text)
    res = snakesim("check", "robot-zero-g", "--urdf", str(user))
    assert res.exit_code != 0
    msg = res.output
    assert "odd.urdf" in msg and "eels-1.0" in msg
    assert "segment_09" in msg and "module_09" in msg
    assert "bend_04" in msg and "prismatic" in msg and "revolute" in msg
    assert "Traceback" not in msg


@pytest.mark.parametrize("args, expected", [
    (("--modules", "0"), ["modules", "greater than or equal to 1", "got 0"]),
    (("--modules", "four"), ["modules", "valid integer", "'four'"]),
    (("--robot", "eels-1.6"), ["unknown robot design 'eels-1.6'", "eels-1.5", "mini-eels-1.0"]),
])
def test_bad_launch_options_are_clear_errors(snakesim, args, expected):
    res = snakesim("check", "robot-zero-g", *args)
    assert res.exit_code != 0
    assert "robot-zero-g.yaml" in res.output and "Traceback" not in res.output
    for text in expected:
        assert text in res.output


def test_head_is_a_launch_option(snakesim):
    """eels-1.0's perception head adds a link and fixed frames but no DOF."""
    with_head = _check(snakesim, "--head", "true")["component_reports"]["robot"]
    without = _check(snakesim, "--head", "false")["component_reports"]["robot"]
    assert with_head["before"]["links"] > without["before"]["links"]
    assert with_head["after"]["dof"] == without["after"]["dof"] == 36
