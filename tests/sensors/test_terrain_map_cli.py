"""``--terrain-map`` and its options (components/sensors/terrain_map_cli.py), the run folder's terrain_map files written as the
run goes (components/sensors/terrain_map_files.py), and ``snakesim terrain sdf``: one test per error class, each
message naming the option or value and what is valid."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
from click.testing import CliRunner

from snakesim.framework.cli import cli, install_plugin_cli

SCENE = """
sim: {duration: 1.0, dt: 0.01}
components:
  terrain: {type: terrain, params: {name: flat-ice}}
  robot: {type: multibody, params: {design: eels-1.0, modules: 2, gravity: [0, 0, 0],
                                    base_position: [0.0, 0.0, 0.3]}}
"""


def _invoke(*args):
    install_plugin_cli()
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "scene.yaml"
    path.write_text(textwrap.dedent(SCENE))
    return path


def test_check_adds_the_map_with_the_options(scene):
    r = _invoke("check", scene, "--terrain-map", "--terrain-map-resolution", 0.2, "--terrain-map-extent", 3,
                "--terrain-map-rate", 4, "--terrain-map-max-slope", 0.3, "--terrain-map-max-step", 0.05)
    assert r.exit_code == 0, r.output
    line = next(ln for ln in r.output.splitlines() if ln.split()[:2] == ["terrain_map", "terrain_map"])
    assert "4 Hz" in line
    from snakesim.components.sensors.terrain_map_cli import attach_terrain_map
    from snakesim.framework.assembly import resolve

    resolved = resolve(str(scene))
    attach_terrain_map(resolved, "module_01", {"extent": 3.0, "resolution": 0.2}, rate=4.0)
    spec = resolved.components["terrain_map"]
    assert spec.params == {"link": "module_01", "extent": 3.0, "resolution": 0.2} and spec.rate == 4.0
    assert ("terrain.terrain", "terrain_map.terrain", "--terrain-map") in resolved.connections


@pytest.mark.parametrize("args, words", [
    (("--terrain-map-resolution", 0), ["--terrain-map-resolution", "0"]),                  # click's range
    (("--terrain-map-max-slope", 2), ["--terrain-map-max-slope", "2"]),
])
def test_values_out_of_range_are_usage_errors(scene, args, words):
    r = _invoke("check", scene, "--terrain-map", *args)
    assert r.exit_code == 2 and all(w in r.output for w in words), r.output


def test_a_grid_too_large_names_the_options_and_the_limit(scene):
    r = _invoke("check", scene, "--terrain-map", "--terrain-map-extent", 500, "--terrain-map-resolution", 0.1)
    assert r.exit_code != 0
    assert "--terrain-map-extent" in r.output and "1000000" in r.output and "5000 × 5000" in r.output, r.output


def test_an_option_without_terrain_map_says_to_add_it(scene):
    r = _invoke("check", scene, "--terrain-map-extent", 6)
    assert r.exit_code != 0 and "--terrain-map-extent" in r.output and "add --terrain-map" in r.output, r.output


def test_a_scene_without_a_robot_is_refused():
    r = _invoke("check", "pendulum", "--terrain-map")
    assert r.exit_code != 0 and "terrain-map needs a robot" in r.output, r.output


def test_a_link_the_robot_lacks_lists_its_links(scene):
    r = _invoke("check", scene, "--terrain-map", "nope")
    assert r.exit_code != 0 and "nope" in r.output and "module_01" in r.output, r.output


def test_files_are_written_while_the_run_goes(scene, tmp_path):
    """Advanced part way (a run killed there), the folder already holds the map of a sample taken so far."""
    from snakesim.components.sensors.terrain_map_cli import attach_terrain_map
    from snakesim.components.sensors.terrain_map_files import NPZ, PNG, load_terrain_map
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry
    from snakesim.framework.session import Session
    from snakesim.framework.simulation import Simulation

    reg = default_registry()
    resolved = resolve(str(scene), search_path=reg.assembly_paths())
    out = tmp_path / "out"
    out.mkdir()
    attach_terrain_map(resolved, None, {"extent": 2.0, "resolution": 0.25}, rate=10.0, out_dir=out, registry=reg)
    spec = resolved.components["terrain_map_files"]             # a picture at once, not after 10 wall s
    resolved.components["terrain_map_files"] = spec.model_copy(update={"params": {**spec.params,
                                                                                  "picture_period": 1e-6}})
    s = Session(resolved, reg)
    sim = Simulation(s.plan, s.integrator, resolved.sim, s)
    sim.advance_to(0.3)
    m = load_terrain_map(out / NPZ)
    assert (m["cost"] == 0).all() and m["cost"].shape == (8, 8)         # flat ice: free
    np.testing.assert_allclose(m["elevation"], 0.0, atol=1e-4)
    assert 0.0 <= float(m["t"]) < 0.3 and (out / PNG).read_bytes()[:4] == b"\x89PNG"


def test_terrain_sdf_writes_the_query_and_says_what_is_wrong(tmp_path):
    from snakesim.components.sensors.terrain_map import load_sdf_volume
    from snakesim.components.terrain.spec import load_terrain

    out = tmp_path / "v.npz"
    r = _invoke("terrain", "sdf", "obstacle-course", "-o", out, "--resolution", 0.1, "--bounds=2,-1,-0.1,3,0,0.5")
    assert r.exit_code == 0, r.output
    v = load_sdf_volume(out)
    assert v["distance"].shape == (11, 11, 7) and v["terrain"] == "obstacle-course"
    terrain = load_terrain("obstacle-course")
    idx = np.array([[0, 0, 0], [4, 2, 3], [10, 10, 6]])
    np.testing.assert_allclose(v["distance"][tuple(idx.T)], terrain.distance(v["origin"] + 0.1 * idx), atol=1e-12)
    # unbounded along x and y: --bounds needed
    r = _invoke("terrain", "sdf", "obstacle-course", "-o", out)
    assert r.exit_code == 2 and "unbounded along x, y" in r.output and "--bounds" in r.output
    r = _invoke("terrain", "sdf", "flat-ice", "-o", out, "--bounds", "0,0,0,1,1")
    assert r.exit_code == 2 and "six numbers" in r.output
    r = _invoke("terrain", "sdf", "flat-ice", "-o", out, "--resolution", 0.001, "--bounds", "0,0,0,1,1,1")
    assert r.exit_code == 2 and "more than 50000000" in r.output
    r = _invoke("terrain", "sdf", "no-such-terrain", "-o", out, "--bounds", "0,0,0,1,1,1")
    assert r.exit_code == 1 and "no-such-terrain" in r.output and "flat-ice" in r.output
    r = _invoke("terrain", "sdf", "flat-ice", "-o", tmp_path / "missing" / "v.npz", "--bounds", "0,0,0,1,1,1")
    assert r.exit_code == 1 and "missing" in r.output and "nothing partial" in r.output
