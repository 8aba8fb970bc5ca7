"""The distribution as users get it: a wheel installed elsewhere, and the editable install.

The wheel test proves the data folders travel inside the wheel and are found
through importlib.resources: it runs from a temporary folder, in a venv that
cannot see the working tree, and asserts snakesim really was imported from
the installed copy before running the scenes.
"""

from __future__ import annotations

import csv
import json
import sys
import zipfile
from pathlib import Path

import pytest

from packaging_helpers import REPO, build_wheel, clean_env, copy_project, make_venv, pip_install, run

pytestmark = pytest.mark.packaging

WHERE = ("import snakesim.framework, snakesim.assemblies as a; from importlib.resources import files; "
         "print(snakesim.framework.__file__); print(files(a))")


def _rows(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _check_run(out: Path, n_rows: int, column: str) -> None:
    summary = json.loads((out / "summary.json").read_text())
    assert summary["completed"], summary["stop_reason"]
    rows = _rows(out / "signals.csv")
    assert len(rows) == n_rows
    assert column in rows[0]
    assert (out / "config.yaml").is_file()


def _data_files(root: Path) -> set[str]:
    """YAML files under the packaged folders, as paths inside the wheel."""
    out = set()
    for folder in ("assemblies", "configs", "robots", "terrains", "campaigns"):
        for p in (root / folder).rglob("*.yaml"):
            if "__pycache__" not in p.parts:
                out.add(f"snakesim/{p.relative_to(root).as_posix()}")
    return out


@pytest.mark.slow
def test_wheel_installs_and_finds_its_data(scratch):
    src = copy_project(scratch / "src")
    wheel = build_wheel(src, scratch / "dist")
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = _data_files(src) - names
    assert not missing, f"data files left out of the wheel (see [tool.setuptools.package-data]): {sorted(missing)}"
    assert "snakesim/assemblies/pendulum.yaml" in names
    assert "snakesim/assemblies/lib/spring-mass-cell.yaml" in names
    entry_points = next(n for n in names if n.endswith(".dist-info/entry_points.txt"))
    assert "snakesim = snakesim.framework.cli:main" in zipfile.ZipFile(wheel).read(entry_points).decode()

    venv = scratch / "venv"
    python = make_venv(venv, editable=False)
    pip_install(python, wheel)
    work = scratch / "work"                       # nowhere near the sources
    work.mkdir()
    env = clean_env(venv)

    framework_file, assemblies_dir = run([python, "-c", WHERE], cwd=work, env=env).stdout.split("\n")[:2]
    assert Path(framework_file).resolve().is_relative_to(venv.resolve()), framework_file
    assert not Path(framework_file).resolve().is_relative_to(REPO), framework_file
    assert Path(assemblies_dir).resolve().is_relative_to(venv.resolve()), assemblies_dir

    snakesim = venv / "bin" / "snakesim"          # the console script the wheel declares
    check = run([snakesim, "check", "mass-spring-chain"], cwd=work, env=env).stdout
    assert str(venv.resolve()) in check or str(venv) in check, check   # the scene came from the install

    run([snakesim, "run", "pendulum", "--duration", "0.1", "--out", work / "pend", "--quiet"], cwd=work, env=env)
    _check_run(work / "pend", 101, "pend.theta")
    # an include of lib/spring-mass-cell.yaml resolved inside the installed package
    run([snakesim, "run", "mass-spring-chain", "--duration", "0.05", "--set", "n=3", "--out", work / "chain",
         "--quiet"], cwd=work, env=env)
    _check_run(work / "chain", 51, "cell2/mass.x")
    # a scene whose robot is a URDF beside the designs' (../robots/specimens/, relative to the scene's file)
    check = run([snakesim, "check", "snow-drawbar-pull"], cwd=work, env=env).stdout
    assert "drawbar_carriage" in check and "specimens/eels-1.0-module.urdf" in check, check


def test_editable_install_finds_the_working_tree(scratch):
    where = run([sys.executable, "-c", WHERE], cwd=scratch, env=clean_env()).stdout.split("\n")[:2]
    if not Path(where[0]).resolve().is_relative_to(REPO):
        pytest.skip(f"snakesim here is not the editable install of {REPO} ({where[0]})")
    assert Path(where[1]).resolve() == (REPO / "assemblies").resolve()
    snakesim = Path(sys.executable).parent / "snakesim"
    cmd = [snakesim] if snakesim.exists() else [sys.executable, "-c", "from snakesim.framework.cli import main; main()"]
    check = run([*cmd, "check", "mass-spring-chain"], cwd=scratch, env=clean_env()).stdout
    assert str(REPO / "assemblies" / "mass-spring-chain.yaml") in check
    run([*cmd, "run", "mass-spring-chain", "--duration", "0.05", "--out", scratch / "chain", "--quiet"],
        cwd=scratch, env=clean_env())
    _check_run(scratch / "chain", 51, "cell3/mass.x")


def test_an_editable_plugin_stays_visible_in_wheel_venvs():
    """A wheel venv hides snakesim's own editable install, never an editable plugin's: hiding the plugin's
    finder while its entry point stays visible made `snakesim` fail in the wheel test."""
    from packaging_helpers import is_snakesims_own_editable_hook

    assert is_snakesims_own_editable_hook("__editable__.snakesim-0.1.0.pth")
    assert not is_snakesims_own_editable_hook("__editable__.snakesim_demo_plugin-0.1.0.pth")
    assert not is_snakesims_own_editable_hook("__editable__.snakesim_ros_extras-2.0.pth")


def test_every_packaged_folder_is_declared(scratch):
    """setuptools warns "Package would be ignored" for each data folder setup.py does not list (pages of
    it on `pip install -v`); every folder under the packaged roots must be a declared package."""
    from packaging_helpers import can_build_offline

    if not can_build_offline():
        pytest.skip("needs setuptools and wheel in this environment (pip install -e .[test])")
    src = copy_project(scratch / "src")
    proc = run([sys.executable, "-m", "pip", "wheel", "-v", "--no-deps", "--no-build-isolation", "--no-index",
                "--disable-pip-version-check", "-w", scratch / "dist", src], cwd=src, env=clean_env(), timeout=300)
    output = proc.stdout + proc.stderr
    assert "would be ignored" not in output, [ln for ln in output.splitlines() if "recognizes" in ln]
