"""--terrain on a surface scene puts the robot on the new terrain (placement/terrain_swap.py), or refuses."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from snakesim.components.placement.terrain_swap import TerrainPlacementError, vertical_rest_shift
from snakesim.components.terrain.spec import load_terrain
from snakesim.framework.cli import cli, install_plugin_cli


def _run(tmp_path, terrain):
    install_plugin_cli()
    out = tmp_path / terrain
    # a contact deeper than 5 mm stops the run: the first contact depths are a few mm at most
    res = CliRunner().invoke(cli, ["run", "--robot", "eels-1.0-front", "--modules", "6", "--terrain", terrain,
                                   "--duration", "0.04", "--set", "components.contact.params.max_depth=0.005",
                                   "--out", str(out)])
    return res, out


@pytest.mark.parametrize("terrain", ["fractal-dem", "tilted-plane-20deg"])
def test_terrain_option_places_the_robot_on_it(tmp_path, terrain):
    res, out = _run(tmp_path, terrain)
    assert res.exit_code == 0, res.output
    assert f"--terrain {terrain}: robot placed on it (base raised" in res.output
    summary = yaml.safe_load((out / "summary.json").read_text())
    assert summary["outcome"] == "success" and summary["sim_time_s"] > 0.03, summary
    base = yaml.safe_load((out / "config.yaml").read_text())["components"]["robot"]["params"]["base_position"]
    assert base[2] > 0.0898 + 0.01          # raised from the scene's flat-ice placement, and kept in config.yaml


def test_vertical_rest_shift_touches_the_lowest_point():
    dem = load_terrain("fractal-dem")
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-1, 1, 50), rng.uniform(-1, 1, 50), rng.uniform(-0.3, 0.3, 50)])
    dz = vertical_rest_shift(pts, dem)
    assert abs(dem.distance(pts + [0, 0, dz]).min()) < 5e-4


def test_terrain_that_cannot_carry_the_robot_is_refused(tmp_path):
    walls = load_terrain("parallel-walls-0.35")
    with pytest.raises(TerrainPlacementError, match="cannot place the robot"):
        vertical_rest_shift(np.array([[0.0, 0.5, 0.0]]), walls)
    install_plugin_cli()
    res = CliRunner().invoke(cli, ["check", "--robot", "eels-1.0-front", "--modules", "6",
                                   "--terrain", "parallel-walls-0.35"])
    assert res.exit_code == 1 and "cannot place the robot" in res.output and "Traceback" not in res.output
