"""load_robot API, parameter validation, and the committed files staying fresh."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest

from snakesim.robots import DESIGNS, UnknownDesignError, generate_robot, load_robot, metadata_yaml
from snakesim.robots.description import URDF_DIR
from snakesim.robots.generate import main as generate_main


@pytest.mark.parametrize("design", list(DESIGNS))
def test_committed_files_equal_fresh_generation(design):
    robot = generate_robot(design)
    assert (URDF_DIR / f"{design}.urdf").read_text(encoding="utf-8") == robot.urdf, (
        "stale committed URDF: run python -m snakesim.robots.generate"
    )
    assert (URDF_DIR / f"{design}.yaml").read_text(encoding="utf-8") == metadata_yaml(robot.metadata)
    assert robot.missing_meshes() == []


def test_generate_check_passes_on_committed_files():
    assert generate_main(["--check"]) == 0


def test_generate_cli_writes_a_variant(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "snakesim.robots.generate", "--out", str(tmp_path), "--design", "eels-1.0",
         "--modules", "3"],
        capture_output=True, text=True, check=False,
    )
    assert result.returncode == 0, result.stderr
    text = (tmp_path / "urdf" / "eels-1.0.urdf").read_text()
    assert text == generate_robot("eels-1.0", modules=3).urdf
    assert list((tmp_path / "meshes").glob("screw_*.stl"))


def test_generate_refuses_to_overwrite_package_files_with_a_variant(capsys):
    with pytest.raises(SystemExit):
        generate_main(["--modules", "3"])
    assert "--modules needs --out" in capsys.readouterr().err


def test_load_robot_defaults_point_at_committed_file():
    robot = load_robot("eels-1.0")
    assert robot.design == "eels-1.0" and robot.modules == 10 and robot.source == "generated"
    assert robot.urdf_path == URDF_DIR / "eels-1.0.urdf"
    assert robot.metadata["module_count"] == 10


def test_variant_is_in_memory_but_reuses_committed_meshes():
    robot = load_robot("eels-1.0", modules=4)
    assert robot.urdf_path is None and robot.modules == 4
    assert robot.base_dir == URDF_DIR
    assert robot.missing_meshes() == []  # screw geometry does not depend on the module count


@pytest.mark.parametrize("modules", [0, -3, 101, 2.5, True, "4", float("nan")])
def test_bad_module_count(modules):
    with pytest.raises(ValueError) as caught:
        load_robot("eels-1.0", modules=modules)
    message = str(caught.value)
    assert repr(modules) in message or str(modules) in message
    assert "1" in message and "100" in message


def test_module_count_range_limits_are_inclusive():
    assert generate_robot("mini-eels-1.0", modules=1).modules == 1
    robot = generate_robot("mini-eels-1.0", modules=100)
    assert "module_99" in robot.urdf and "module_100" not in robot.urdf


def test_unknown_design_lists_valid_names_and_close_matches():
    with pytest.raises(UnknownDesignError) as caught:
        load_robot("eels-10")
    message = str(caught.value)
    assert isinstance(caught.value, ValueError) and isinstance(caught.value, KeyError)
    assert "Did you mean 'eels-1.0'" in message
    for name in DESIGNS:
        assert name in message
    with pytest.raises(UnknownDesignError, match="Did you mean 'mini-eels-1.0'"):
        load_robot("mini")


@pytest.mark.parametrize(
    "kwargs, fragment",
    [
        (dict(lead_angle=0.0), "lead_angle"),
        (dict(lead_angle=math.pi / 2), "lead_angle"),
        (dict(lead_angle=-0.2), "lead_angle"),
        (dict(hand="clockwise"), "hand"),
        (dict(screw_radius=0.0), "screw_radius"),
        (dict(module_length=0.05), "module_length"),
        (dict(head="yes"), "head"),
    ],
)
def test_bad_parameters(kwargs, fragment):
    with pytest.raises(ValueError, match=fragment):
        load_robot("eels-1.0", **kwargs)


def test_parameters_that_do_not_apply():
    with pytest.raises(ValueError, match="has no screws"):
        load_robot("mini-eels-1.0", hand="left")
    with pytest.raises(ValueError, match="no head option"):
        load_robot("eels-1.5", head=True)
    with pytest.raises(TypeError, match="unknown robot parameter"):
        load_robot("eels-1.0", number_of_modules=3)
