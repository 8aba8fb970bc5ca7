"""A third-party plugin, installed as users install one, registers and runs.

tests/plugin_pkg is built into a wheel and installed into a fresh venv that
sees this environment's snakesim; the installed ``snakesim`` then lists the
plugin's component, finds the plugin's scene by name and runs it. The
physics of the output is checked against the filter's step response
y(t) = 1 - exp(-t/tau).
"""

from __future__ import annotations

import csv
import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from packaging_helpers import REPO, build_wheel, clean_env, make_venv, pip_install, run

pytestmark = pytest.mark.packaging

PLUGIN = REPO / "tests" / "plugin_pkg"
#: the snakesim command line, run by the venv's interpreter
CLI = ["-c", "from snakesim.framework.cli import main; main()"]


def _columns(path: Path) -> dict[str, np.ndarray]:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    data = np.array(rows[1:], dtype=float)
    return {name: data[:, i] for i, name in enumerate(rows[0])}


@pytest.fixture
def plugin_venv(scratch):
    src = scratch / "plugin_src"
    shutil.copytree(PLUGIN, src, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info", "build", "tests"))
    wheel = build_wheel(src, scratch / "dist")
    venv = scratch / "venv"
    python = make_venv(venv, editable=True)
    pip_install(python, wheel)
    return venv, python


@pytest.mark.slow
def test_installed_plugin_registers_and_runs(plugin_venv, scratch):
    venv, python = plugin_venv
    work = scratch / "work"
    work.mkdir()
    env = clean_env(venv)

    listing = json.loads(run([python, *CLI, "components", "--json"], cwd=work, env=env).stdout)
    assert "demo_lowpass" in listing, sorted(listing)
    assert listing["demo_lowpass"]["module"] == "snakesim_demo_plugin.lowpass"
    assert "pendulum" in listing                 # built-ins still there

    tau = 0.05
    run([python, *CLI, "run", "lowpass-step", "--set", f"tau={tau}", "--out", work / "run", "--quiet"],
        cwd=work, env=env)
    summary = json.loads((work / "run" / "summary.json").read_text())
    assert summary["completed"], summary["stop_reason"]
    cols = _columns(work / "run" / "signals.csv")
    t, y = cols["t"], cols["filter.y[0]"]
    assert t[-1] == pytest.approx(0.5) and len(t) == 501
    # rk4 at dt/tau = 0.02 is good to ~5e-10; a first-order method would be off by ~1e-2
    np.testing.assert_allclose(y, 1.0 - np.exp(-t / tau), rtol=0, atol=1e-8)
    # one time constant: 63.2 % of the step
    assert y[np.searchsorted(t, tau)] == pytest.approx(1 - np.exp(-1), abs=1e-8)


def test_plugin_is_invisible_where_not_installed(scratch):
    # this environment never had the plugin installed: its registry must not know it
    out = run([sys.executable, *CLI, "components", "--json"], cwd=scratch, env=clean_env()).stdout
    assert "demo_lowpass" not in json.loads(out)
