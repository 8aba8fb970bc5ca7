"""Every command README.md shows runs as pasted, after the set-up line; so does every command of the
pages the README's sections moved to (docs/viewer.md, docs/perception.md, docs/ros2.md).

Each page's commands run in a scratch folder of their own. Each line of a ```bash``` block, and each ``$ `` line of a ```console``` block, is split at ``&&``
and run in page order in one scratch folder (the repository's ``configs/`` linked in, since the
tour names a file there), so a command may use what an earlier one wrote (``--out runs/p1``, then
``run runs/p1/config.yaml``). ``snakesim`` commands run in-process through click with the
environment activated, as the tour says. Left out, and why:

- set-up lines that create the venv and install packages (``python3 -m venv``, ``pip install``):
  the environment running this test is that set-up's result; ``source .venv/bin/activate``
  is what running in it means; their ``pytest`` would run this very suite;
- the ROS 2 block (docs/ros2.md) that starts ``snakesim run --ros2-commands ... &`` and ``python ros2_node.py``:
  tests/docs/test_ros2_readme.py runs it; ``ros2 ...`` lines need a ROS 2 installation;
- ``export`` lines (they only configure that ROS 2 block).

Durations: every ``snakesim run`` gets ``--duration 0.04`` appended (click keeps the last value, so
it also shortens ``--duration 20``): the commands are checked for running, not for physics, which
their own tests check.
"""

from __future__ import annotations

import os
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from doc_blocks import DOCS, blocks

REPO = Path(__file__).resolve().parents[2]
PAGE = "../README.md"
#: the pages README sections moved to, relative to docs/ (their commands run as the README's do)
MOVED_PAGES = ("viewer.md", "perception.md", "ros2.md")
PAGES = (PAGE,) + MOVED_PAGES
SHORT = ["--duration", "0.04"]     # whole steps of 1, 2, 4, 5, 10 and 20 ms
SET_UP = ("python3 -m venv", "pip install", "source .venv/bin/activate")
TESTED_ELSEWHERE = ("--ros2-commands", "python ros2_node.py")      # tests/docs/test_ros2_readme.py
NEEDS_ROS = ("ros2 ", "export ")


def readme_commands(page: str = PAGE) -> list[tuple[int, list[str]]]:
    """(line, argv) of every command a page shows, in page order, set-up and ROS 2 lines left out."""
    out = []
    for b in blocks(page):
        if b.lang == "bash":
            lines = b.text.splitlines()
        elif b.lang == "console":
            lines = [ln[2:] for ln in b.text.splitlines() if ln.startswith("$ ")]
        else:
            continue
        for n, line in enumerate(lines):
            if any(s in line for s in SET_UP + TESTED_ELSEWHERE) or line.lstrip().startswith(NEEDS_ROS):
                continue
            for part in line.split("&&"):
                argv = shlex.split(part, comments=True)
                if argv:
                    out.append((b.line + 1 + n, argv))
    return out


def _name(page: str) -> str:
    return (DOCS / page).resolve().relative_to(REPO).as_posix()


@pytest.mark.parametrize("page", PAGES)
def test_the_page_names_no_file_a_clone_lacks(page):
    text = (DOCS / page).read_text()
    assert "../shared" not in text
    assert readme_commands(page), f"no commands found in {_name(page)}"
    for line, argv in readme_commands(page):
        assert argv[0] == "snakesim", f"{_name(page)}:{line}: only snakesim commands are expected here: {argv}"


def _run_page(page, tmp_path, monkeypatch):
    from snakesim.framework.cli import cli, install_plugin_cli

    install_plugin_cli()
    (tmp_path / "configs").symlink_to(REPO / "configs")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CI", "1")                 # --viz spawn saves instead of opening a window
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    for line, argv in readme_commands(page):
        args = argv[1:] + (SHORT if argv[1:2] == ["run"] else [])
        result = CliRunner().invoke(cli, args, catch_exceptions=False)
        if result.exit_code != 0:
            pytest.fail(f"{_name(page)}:{line}: `{shlex.join(argv)}` exited {result.exit_code}:\n{result.output}",
                        pytrace=False)


def test_every_readme_command_runs(tmp_path, monkeypatch):
    _run_page(PAGE, tmp_path, monkeypatch)
    # what the tour's later commands read, the earlier ones wrote
    runs = tmp_path / "runs"
    assert (runs / "my-eels.urdf").is_file() and (runs / "meshes").is_dir() and (runs / "p1" / "config.yaml").is_file()
    assert (runs / "c1" / "replay.rrd").is_file() and (runs / "chain.svg").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["configs", "runs"], "the tour writes under runs/ only"


@pytest.mark.parametrize("page", MOVED_PAGES)
def test_every_command_of_a_moved_page_runs(page, tmp_path, monkeypatch):
    _run_page(page, tmp_path, monkeypatch)
