"""Helpers for the packaging tests: build wheels, make throw-away environments.

A fresh environment must not need the network, so each one is a bare venv
(``python -m venv --without-pip``, a few milliseconds) that sees the
*current* environment's installed dependencies through a ``.pth`` hook, the
way ``--system-site-packages`` would see the base interpreter's. With
``editable=False`` the hook skips the editable-install finder of snakesim
itself, so ``import snakesim`` can only resolve to what was installed into
the new venv. Packages go in with the current environment's pip
(``pip --python NEW``), ``--no-deps --no-index``: nothing is downloaded.

Wheels are built from a copy of the sources in a temporary folder, so a
build never writes ``build/`` or ``*.egg-info`` into the working tree, and
offline (``--no-build-isolation``) whenever this environment has what the
build backend needs (setuptools and wheel, i.e. ``pip install -e .[test]``);
otherwise pip builds in an isolated environment fetched from the index.
"""

from __future__ import annotations

import importlib.util
import inspect
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
#: the top-level folders setup.py maps onto the snakesim namespace
PROJECT_FOLDERS = ("framework", "components", "campaigns", "assemblies", "robots", "terrains", "configs", "gymenv")
PROJECT_FILES = ("pyproject.toml", "setup.py", "README.md", "LICENSE")

_PARENT_HOOK = '''"""Added by snakesim's packaging tests: see the parent environment's packages."""
import os, site, sys
{hidden_test}
PARENT = {parent!r}
EDITABLE = {editable!r}
if PARENT not in sys.path:
    sys.path.append(PARENT)
    for _name in sorted(os.listdir(PARENT)):
        if _name.endswith(".pth") and (EDITABLE or not is_snakesims_own_editable_hook(_name)):
            site.addpackage(PARENT, _name, set(sys.path))
'''


def is_snakesims_own_editable_hook(name):
    """The .pth of snakesim's own editable install (``__editable__.snakesim-0.1.0.pth``), and only it: an
    editable *plugin* (``__editable__.snakesim_demo_plugin-0.1.0.pth``) stays visible, or its entry point
    would be found with no module behind it and every snakesim command in the venv would fail."""
    return name.startswith("__editable__.snakesim-")


def run(cmd, *, cwd, env=None, timeout=120) -> subprocess.CompletedProcess:
    """Run a command; on failure, fail the test with its full output."""
    proc = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)
    if proc.returncode != 0:
        pytest.fail(f"command failed ({proc.returncode}): {' '.join(map(str, cmd))}\n"
                    f"--- stdout\n{proc.stdout}\n--- stderr\n{proc.stderr}", pytrace=False)
    return proc


def clean_env(venv: Path | None = None) -> dict:
    """The environment for a subprocess: no PYTHONPATH, no user site, the venv's bin first."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env["PYTHONNOUSERSITE"] = "1"
    env["MPLBACKEND"] = "Agg"
    if venv is not None:
        env["VIRTUAL_ENV"] = str(venv)
        env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    return env


def can_build_offline() -> bool:
    """setuptools with a bdist_wheel command: built in from 70.1, else the wheel package."""
    if importlib.util.find_spec("setuptools") is None:
        return False
    if importlib.util.find_spec("wheel") is not None:
        return True
    import setuptools
    major, minor = (int(p) for p in setuptools.__version__.split(".")[:2])
    return (major, minor) >= (70, 1)


def build_wheel(src: Path, out: Path) -> Path:
    """Build the wheel of the project at ``src`` into ``out``; returns its path."""
    out.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--disable-pip-version-check", "-w", out, src]
    if can_build_offline():
        cmd[4:4] = ["--no-build-isolation", "--no-index"]
    run(cmd, cwd=src, env=clean_env(), timeout=300)
    wheels = sorted(out.glob("*.whl"))
    assert len(wheels) == 1, f"expected one wheel in {out}, found {[w.name for w in wheels]}"
    return wheels[0]


def copy_project(dest: Path) -> Path:
    """The project's packaged sources, copied without caches or build leftovers."""
    dest.mkdir(parents=True)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build", "dist")
    for name in PROJECT_FOLDERS:
        if (REPO / name).is_dir():
            shutil.copytree(REPO / name, dest / name, ignore=ignore)
    for name in PROJECT_FILES:
        if (REPO / name).is_file():
            shutil.copy2(REPO / name, dest / name)
    return dest


def make_venv(path: Path, *, editable: bool) -> Path:
    """A bare venv that sees this environment's packages; returns its python.

    ``editable=True`` keeps this environment's editable snakesim visible (to
    test a plugin against the working tree); ``False`` hides it (to test an
    installed wheel).
    """
    run([sys.executable, "-m", "venv", "--without-pip", path], cwd=path.parent, env=clean_env())
    python = path / "bin" / "python"
    site_dir = Path(run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                        cwd=path, env=clean_env()).stdout.strip())
    site_dir.mkdir(parents=True, exist_ok=True)
    parent = sysconfig.get_paths()["purelib"]
    (site_dir / "_snakesim_test_parent.py").write_text(_PARENT_HOOK.format(
        parent=parent, editable=editable, hidden_test=inspect.getsource(is_snakesims_own_editable_hook)))
    (site_dir / "_snakesim_test_parent.pth").write_text("import _snakesim_test_parent\n")
    return python


def pip_install(python: Path, *wheels: Path) -> None:
    """Install wheels into the venv of ``python`` with this environment's pip, offline."""
    run([sys.executable, "-m", "pip", "--python", python, "install", "--no-deps", "--no-index",
         "--disable-pip-version-check", *wheels], cwd=python.parent, env=clean_env())
