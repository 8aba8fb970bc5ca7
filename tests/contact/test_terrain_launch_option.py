"""--terrain swaps the terrain of any robot scene (a name in terrains/ or a path)."""

from __future__ import annotations

import yaml
from click.testing import CliRunner

from snakesim.framework.cli import cli, install_plugin_cli


def test_terrain_option_swaps_the_scene_terrain(tmp_path):
    install_plugin_cli()
    out = tmp_path / "run"
    res = CliRunner().invoke(cli, ["run", "contact-screw-drive", "--terrain", "fractal-dem", "--modules", "2",
                                   "--duration", "0.01", "--quiet", "--out", str(out)])
    # the scene places its robot for flat ground; on the fractal DEM its screws would start inside a bump
    # (the contact's depth guard ended the run at t = 0): --terrain raises it onto the DEM
    # (components/placement/terrain_swap.py), so the run completes; the config is written
    assert res.exit_code == 0, res.output
    cfg = yaml.safe_load((out / "config.yaml").read_text())
    assert cfg["components"]["terrain"]["params"]["name"] == "fractal-dem"


def test_unknown_terrain_lists_the_available_ones():
    install_plugin_cli()
    res = CliRunner().invoke(cli, ["check", "contact-screw-drive", "--terrain", "flat-ise"])
    assert res.exit_code != 0 and "Traceback" not in res.output
    assert "flat-ise" in res.output and "flat-ice" in res.output
