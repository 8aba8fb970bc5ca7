"""`snakesim robot urdf`: a design's URDF for N modules, with its meshes, that loads as that robot."""

from __future__ import annotations

import re

from click.testing import CliRunner

from snakesim.components.multibody import RobotModel
from snakesim.framework.cli import cli


def test_writes_a_urdf_of_n_modules_that_loads_with_its_meshes(tmp_path):
    out = tmp_path / "robots" / "my-eels.urdf"
    res = CliRunner().invoke(cli, ["robot", "urdf", "--robot", "eels-1.0", "--modules", "3", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert str(out) in res.output
    model = RobotModel.load(urdf=str(out))
    assert sorted(j for j in model.joints if j.startswith("bend_")) == ["bend_00", "bend_01", "bend_02"]
    # the same robot as the design's: a user URDF of eels-1.0, 3 modules, passes the structure check
    assert RobotModel.load(design="eels-1.0", modules=3, urdf=str(out)).joints == model.joints
    meshes = re.findall(r'filename="([^"]+)"', out.read_text())
    assert meshes and all((out.parent / m).is_file() for m in meshes), meshes


def test_bad_design_and_module_count_are_named(tmp_path):
    res = CliRunner().invoke(cli, ["robot", "urdf", "--robot", "eels-9", "-o", str(tmp_path / "x.urdf")])
    assert res.exit_code != 0 and "eels-9" in res.output
    res = CliRunner().invoke(cli, ["robot", "urdf", "--robot", "eels-1.0", "--modules", "0",
                                   "-o", str(tmp_path / "x.urdf")])
    assert res.exit_code != 0 and "module count 0" in res.output
    assert not (tmp_path / "x.urdf").exists()
