"""Every command README.md shows runs as pasted, after the set-up line.

Each line of a ```bash``` block, and each ``$ `` line of a ```console``` block, is split at ``&&``
and run in page order in one scratch folder (the repository's ``configs/`` linked in, since the
tour names a file there), so a command may use what an earlier one wrote (``--out runs/p1``, then
``run runs/p1/config.yaml``). ``snakesim`` commands run in-process through click with the
environment activated, as the tour says. Left out, and why:

- set-up lines that create the venv and install packages (``python3 -m venv``, ``pip install``):
  the environment running this test is that set-up's result; ``source .venv/bin/activate``
  is what running in it means; their ``pytest`` would run this very suite;
- the ROS 2 block that starts ``snakesim run --ros2-commands ... &`` and ``python ros2_node.py``:
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

from doc_blocks import blocks

REPO = Path(__file__).resolve().parents[2]
PAGE = "../README.md"
SHORT = ["--duration", "0.04"]     # whole steps of 1, 2, 4, 5, 10 and 20 ms
SET_UP = ("python3 -m venv", "pip install", "source .venv/bin/activate")
TESTED_ELSEWHERE = ("--ros2-commands", "python ros2_node.py")      # tests/docs/test_ros2_readme.py
NEEDS_ROS = ("ros2 ", "export ")


def readme_commands() -> list[tuple[int, list[str]]]:
    """(line, argv) of every command the README shows, in page order, set-up and ROS 2 lines left out."""
    out = []
    for b in blocks(PAGE):
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


def test_the_readme_names_no_file_a_clone_lacks():
    text = (REPO / "README.md").read_text()
    assert "../shared" not in text
    assert readme_commands(), "no commands found in README.md"
    for line, argv in readme_commands():
        assert argv[0] == "snakesim", f"README.md:{line}: only snakesim commands are expected here: {argv}"


def test_every_readme_command_runs(tmp_path, monkeypatch):
    from snakesim.framework.cli import cli, install_plugin_cli

    install_plugin_cli()
    (tmp_path / "configs").symlink_to(REPO / "configs")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CI", "1")                 # --viz spawn saves instead of opening a window
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    for line, argv in readme_commands():
        args = argv[1:] + (SHORT if argv[1:2] == ["run"] else [])
        result = CliRunner().invoke(cli, args, catch_exceptions=False)
        if result.exit_code != 0:
            pytest.fail(f"README.md:{line}: `{shlex.join(argv)}` exited {result.exit_code}:\n{result.output}",
                        pytrace=False)
    # what the tour's later commands read, the earlier ones wrote
    assert (tmp_path / "my-eels.urdf").is_file() and (tmp_path / "runs" / "p1" / "config.yaml").is_file()
    assert (tmp_path / "runs" / "c1" / "replay.rrd").is_file() and (tmp_path / "runs" / "chain.svg").is_file()
    assert not any(p.name in ("ice.yaml", "chain.svg") for p in tmp_path.iterdir()), "tour writes under runs/"
