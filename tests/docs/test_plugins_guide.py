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
"""

from __future__ import annotations

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from doc_blocks import assembled_files

PLUGIN = Path(__file__).resolve().parents[2] / "tests" / "plugin_pkg"
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


def test_the_page_prints_the_demo_plugin_whole():
    printed = assembled_files("plugins.md")
    assert set(printed) == _package_files(PLUGIN), "the page must print every file of tests/plugin_pkg"
    for name, text in printed.items():
        assert text == (PLUGIN / name).read_text(), f"docs/plugins.md prints {name} differently from tests/plugin_pkg"


def test_the_printed_plugin_installs_and_passes_its_tests(tmp_path):
    pytest.importorskip("setuptools")
    pkg, site = tmp_path / "snakesim-demo-plugin", tmp_path / "site"
    for name, text in assembled_files("plugins.md").items():
        (pkg / name).parent.mkdir(parents=True, exist_ok=True)
        (pkg / name).write_text(text)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env.update(PYTHONNOUSERSITE="1", MPLBACKEND="Agg")
    _run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "--no-index",
          "--disable-pip-version-check", "--quiet", "--target", site, pkg], tmp_path, env)
    assert (site / "snakesim_demo_plugin" / "lowpass.py").is_file()

    # the page's own tests, from the package folder, as the page says to run them
    out = _run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests"], pkg, env)
    assert " passed" in out and "failed" not in out, out

    # installed: snakesim finds the entry point, lists the component and runs the scene by name
    env["PYTHONPATH"] = str(site)
    snakesim = [sys.executable, "-c", "from snakesim.framework.cli import main; main()"]
    work = tmp_path / "work"
    work.mkdir()
    assert "demo_lowpass" in _run([*snakesim, "components"], work, env)
    _run([*snakesim, "run", "lowpass-step", "--set", "tau=0.05", "--duration", "0.2", "--quiet",
          "--out", "runs/lowpass"], work, env)
    with open(work / "runs" / "lowpass" / "signals.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows[::20]:
        t, y = float(r["t"]), float(r["filter.y[0]"])
        assert y == pytest.approx(1.0 - math.exp(-t / 0.05), abs=1e-6)
