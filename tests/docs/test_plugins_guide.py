"""docs/plugins.md builds a working plugin exactly as printed.

The page prints every file of the demo plugin (``title="FILE"`` blocks; ``lowpass.py`` in parts,
top to bottom). Here those blocks are written into a fresh folder, installed the way a user
installs a package (pip, offline: ``--no-deps --no-build-isolation --no-index`` with this
environment's setuptools, into a throw-away ``--target`` folder put on PYTHONPATH), and then the
package's own tests run in a subprocess, and the ``snakesim`` of this environment lists the
installed plugin's component and runs its scene by name. A page that omits ``version``,
``[build-system]``, an import or the conftest fails here. tests/plugin_pkg is the same package,
kept identical to the page (the first test), so tests/packaging/test_plugin.py installs what the
page prints.

The page's second package, a terrain kind (blocks titled ``terrain-plugin/FILE``), is installed the
same way; its tests run, and the installed ``snakesim`` runs its scene: the contact carries the
robot's weight, every lidar return lies on the kind's surface, the viewer's recording holds its mesh.

The third, a robot design (blocks titled ``design-plugin/FILE``), likewise: its tests run, and the
installed ``snakesim`` runs its scene (the design on flat ice, named by ``design:`` with no file of
snakesim edited): the screw contact, reading the screws from the design's metadata, carries the
URDF's mass times g; ``snakesim robot urdf`` writes the design with its metadata sidecar.
"""

from __future__ import annotations

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from doc_blocks import assembled_files

PLUGIN = Path(__file__).resolve().parents[2] / "tests" / "plugin_pkg"
#: the page's terrain-kind package: its blocks' titles start with this
TERRAIN = "terrain-plugin/"
#: the page's robot-design package
DESIGN = "design-plugin/"
#: files of tests/plugin_pkg the page need not print
NOT_PRINTED = {"README.md"}


def _package_files(root: Path) -> set[str]:
    return {p.relative_to(root).as_posix() for p in root.rglob("*")
            if p.is_file() and "__pycache__" not in p.parts and ".egg-info" not in p.as_posix()
            and p.name not in NOT_PRINTED}


def _run(cmd, cwd, env, timeout=300) -> str:
    proc = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0:
        pytest.fail(f"`{' '.join(map(str, cmd))}` exited {proc.returncode}:\n{proc.stdout}\n{proc.stderr}",
                    pytrace=False)
    return proc.stdout + proc.stderr


def _component_plugin_files() -> dict[str, str]:
    return {k: v for k, v in assembled_files("plugins.md").items() if not k.startswith((TERRAIN, DESIGN))}


def test_the_page_prints_the_demo_plugin_whole():
    printed = _component_plugin_files()
    assert set(printed) == _package_files(PLUGIN), "the page must print every file of tests/plugin_pkg"
    for name, text in printed.items():
        assert text == (PLUGIN / name).read_text(), f"docs/plugins.md prints {name} differently from tests/plugin_pkg"


def _install_and_test(files: dict[str, str], tmp_path: Path, folder: str):
    """Write a printed package into ``tmp_path/folder``, pip-install it (offline) into ``tmp_path/site``
    and run its own tests from its folder, as the page says to; -> (site, environment that sees the
    installed package, the ``snakesim`` command, an empty work folder)."""
    pytest.importorskip("setuptools")
    pkg, site = tmp_path / folder, tmp_path / "site"
    for name, text in files.items():
        (pkg / name).parent.mkdir(parents=True, exist_ok=True)
        (pkg / name).write_text(text)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env.update(PYTHONNOUSERSITE="1", MPLBACKEND="Agg")
    _run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "--no-index",
          "--disable-pip-version-check", "--quiet", "--target", site, pkg], tmp_path, env)

    out = _run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests"], pkg, env)
    assert " passed" in out and "failed" not in out, out

    env["PYTHONPATH"] = str(site)
    work = tmp_path / "work"
    work.mkdir()
    return site, env, [sys.executable, "-c", "from snakesim.framework.cli import main; main()"], work


@pytest.mark.slow
def test_the_printed_plugin_installs_and_passes_its_tests(tmp_path):
    site, env, snakesim, work = _install_and_test(_component_plugin_files(), tmp_path, "snakesim-demo-plugin")
    assert (site / "snakesim_demo_plugin" / "lowpass.py").is_file()

    # installed: snakesim finds the entry point, lists the component and runs the scene by name
    assert "demo_lowpass" in _run([*snakesim, "components"], work, env)
    _run([*snakesim, "run", "lowpass-step", "--set", "tau=0.05", "--duration", "0.2", "--quiet",
          "--out", "runs/lowpass"], work, env)
    with open(work / "runs" / "lowpass" / "signals.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows[::20]:
        t, y = float(r["t"]), float(r["filter.y[0]"])
        assert y == pytest.approx(1.0 - math.exp(-t / 0.05), abs=1e-6)


def _quat_matrix(q) -> np.ndarray:
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


@pytest.mark.slow
def test_the_printed_terrain_kind_installs_and_every_consumer_sees_it(tmp_path):
    pytest.importorskip("rerun")
    import xml.etree.ElementTree as ET

    import rerun.chunk as rc

    from snakesim.components.multibody.robot_model import RobotModel

    files = {k[len(TERRAIN):]: v for k, v in assembled_files("plugins.md").items() if k.startswith(TERRAIN)}
    assert {"pyproject.toml", "src/snakesim_demo_terrain/dome.py", "tests/test_demo_dome.py"} <= set(files)
    site, env, snakesim, work = _install_and_test(files, tmp_path, "terrain-plugin")

    # installed: the scene's terrain is the plugin's kind, with no file of snakesim edited
    _run([*snakesim, "run", "dome-rest", "--quiet", "--viz", "save", "dome.rrd", "--out", "runs/dome"], work, env)

    # the contact carries the robot's weight once it has settled
    with open(work / "runs" / "dome" / "signals.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    robot = RobotModel.load(design="mini-eels-1.0", modules=4)
    mass = sum(float(m.get("value")) for m in ET.fromstring(robot.urdf).iter("mass"))
    assert float(rows[-1]["contact.normal_force[0]"]) == pytest.approx(9.81 * mass, rel=2e-3)
    assert float(rows[-1]["lidar.returns[0]"]) > 500

    # the dome, as its docstring defines it (the scene's parameters)
    center, radius = np.array([0.4, 0.9, -0.2]), 0.6

    def distance(p):
        return np.minimum(p[:, 2], np.linalg.norm(p - center, axis=1) - radius)

    chunks = rc.RrdReader(work / "dome.rrd").stream().to_chunks()

    def last(entity, column):
        """The value of ``column`` at the latest sim time ``entity`` has it (static: sim time 0)."""
        found = [(b.column("sim").to_pylist()[i].total_seconds() if "sim" in b.schema.names else 0.0, v)
                 for b in (c.to_record_batch() for c in chunks if c.entity_path == entity)
                 if column in b.schema.names for i, v in enumerate(b.column(column).to_pylist())]
        assert found, f"the recording has no {entity} {column}"
        return max(found, key=lambda tv: tv[0])[1]

    # the viewer drew the terrain: a mesh on the surface, the dome's top included
    v = np.array(last("/world/physical/terrain", "Mesh3D:vertex_positions"), dtype=float)
    assert np.abs(distance(v)).max() < 0.1 and v[:, 2].max() == pytest.approx(0.4, abs=0.05)
    # the lidar saw it: its last scan's returns, in the world, lie on the ground or the dome
    points = np.array(last("/world/sensors/lidar/scan/points", "Points3D:positions"), dtype=float)
    quat = last("/world/sensors/lidar/scan", "Transform3D:quaternion")[0]
    shift = np.array(last("/world/sensors/lidar/scan", "Transform3D:translation")[0])
    p = points @ _quat_matrix(quat).T + shift
    assert len(p) > 500
    np.testing.assert_allclose(distance(p), 0.0, atol=1e-4)            # rerun stores float32
    assert (np.linalg.norm(p - center, axis=1) - radius < p[:, 2] - 1e-3).sum() > 20     # some on the dome


@pytest.mark.slow
def test_the_printed_robot_design_installs_and_runs_in_a_scene(tmp_path):
    import xml.etree.ElementTree as ET

    from snakesim.components.multibody.robot_model import RobotModel

    files = {k[len(DESIGN):]: v for k, v in assembled_files("plugins.md").items() if k.startswith(DESIGN)}
    assert {"pyproject.toml", "src/snakesim_demo_design/design.py", "tests/test_demo_auger_snake.py",
            "src/snakesim_demo_design/assemblies/auger-snake-ice.yaml"} <= set(files)
    site, env, snakesim, work = _install_and_test(files, tmp_path, "design-plugin")
    assert (site / "snakesim_demo_design" / "design.py").is_file()

    # installed: the scene's robot is the plugin's design, with no file of snakesim edited
    _run([*snakesim, "run", "auger-snake-ice", "--quiet", "--out", "runs/auger"], work, env)
    with open(work / "runs" / "auger" / "signals.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert float(rows[-1]["t"]) == pytest.approx(0.5)

    # its URDF and sidecar, written by the installed command, load without the plugin
    _run([*snakesim, "robot", "urdf", "--robot", "demo-auger-snake", "--modules", "3", "-o", "snake.urdf"], work, env)
    assert (work / "snake.snakesim.yaml").is_file()
    robot = RobotModel.load(urdf=str(work / "snake.urdf"))
    assert robot.joint_kinds == ("screw", "bend", "screw", "bend", "screw")

    # the screw contact, reading the augers from the metadata, carries the URDF's mass times g
    mass = sum(float(m.get("value")) for m in ET.fromstring(robot.urdf).iter("mass"))
    assert mass == pytest.approx(7.5)
    assert float(rows[-1]["contact.normal_force[0]"]) == pytest.approx(9.81 * mass, rel=1e-3)
    for i in range(3):                                  # each module on its own auger
        assert float(rows[-1][f"contact.screw_normal_force.drive_{i}"]) == pytest.approx(9.81 * mass / 3, rel=1e-3)
