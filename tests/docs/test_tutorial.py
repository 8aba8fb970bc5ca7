"""docs/tutorial.md is executable: its files and commands run as written.

Every ```yaml title="FILE"``` block is written to FILE (a later block with
the same title replaces the file, as the tutorial's steps do) and checked
with ``snakesim check``; every ``$ snakesim ...`` line of a ```console```
block runs, in page order, in a scratch folder. Then the outputs the page
quotes, and the physics it claims, are compared with what the runs gave.
"""

from __future__ import annotations

import csv
import json
import math
import re

import numpy as np
import pytest
from click.testing import CliRunner

from doc_blocks import blocks
from snakesim.framework.cli import cli

PAGE = "tutorial.md"


def _invoke(args, where, expect: int = 0):
    result = CliRunner().invoke(cli, args, catch_exceptions=False)
    if result.exit_code != expect:
        pytest.fail(f"docs/{PAGE}:{where}: `snakesim {' '.join(args)}` exited {result.exit_code} (the page says "
                    f"{expect}):\n{result.output}", pytrace=False)
    return result.output


def _quoted_exit(page, i) -> int:
    """The exit status the page quotes for the commands of console block ``i`` (``... exit status N`` in the
    text block right after it; a failure the page demonstrates), else 0."""
    nxt = page[i + 1] if i + 1 < len(page) else None
    m = re.search(r"exit status (\d+)", nxt.text) if nxt is not None and nxt.lang == "text" else None
    return int(m.group(1)) if m else 0


def _columns(path) -> dict[str, np.ndarray]:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    data = np.array(rows[1:], dtype=float)
    return {name: data[:, i] for i, name in enumerate(rows[0])}


def _period(t, x) -> float:
    """Twice the mean time between zero crossings (linear interpolation)."""
    i = np.flatnonzero(np.sign(x[:-1]) != np.sign(x[1:]))
    tc = t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])
    assert tc.size >= 3, "too few zero crossings to measure a period"
    return 2.0 * float(np.mean(np.diff(tc)))


@pytest.fixture(scope="module")
def tutorial(tmp_path_factory):
    """Play the whole page once; returns (folder, first version of each file, the blocks)."""
    import os

    work = tmp_path_factory.mktemp("tutorial")
    old = os.getcwd()
    os.chdir(work)
    first = {}
    try:
        page = blocks(PAGE)
        assert any(b.title for b in page) and any(b.commands() for b in page), "no runnable blocks found"
        for i, b in enumerate(page):
            if b.lang == "yaml" and b.title:
                path = work / b.title
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(b.text)
                first.setdefault(b.title, b.text)
                if "components:" in b.text or "include:" in b.text:   # an assembly, not a config file
                    _invoke(["check", b.title], b.line)
            elif b.lang == "console":
                for cmd in b.commands():
                    assert cmd[0] == "snakesim", f"docs/{PAGE}:{b.line}: only snakesim commands run here: {cmd}"
                    _invoke(cmd[1:], b.line, _quoted_exit(page, i))
    finally:
        os.chdir(old)
    return work, first, page


def test_every_step_runs(tutorial):
    work, _, _ = tutorial
    for run in ("damped", "again", "over", "long", "bank"):
        assert (work / "runs" / run / "signals.csv").is_file(), run
    assert (work / "pendulum.svg").stat().st_size > 1000
    assert (work / "bank.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_quoted_outputs_are_real(tutorial, monkeypatch):
    work, first, page = tutorial
    monkeypatch.chdir(work)
    texts = [b.text for b in page if b.lang == "text"]

    # step 1's `check` report, from the first version of pendulum.yaml
    (work / "step1.yaml").write_text(first["pendulum.yaml"])
    quoted = next(t for t in texts if t.startswith("pendulum.yaml: 1 components"))
    assert _invoke(["check", "step1.yaml"], "step 1").replace("step1.yaml", "pendulum.yaml") == quoted

    # step 2's unit error, from step 2's file with the rate wired as the angle
    step2 = next(b.text for b in page if b.title == "pendulum.yaml" and "damper" in b.text)
    (work / "pendulum.yaml").write_text(step2.replace("pend.omega -> damper.omega", "pend.theta -> damper.omega"))
    result = CliRunner().invoke(cli, ["check", "pendulum.yaml"])
    quoted = next(t for t in texts if t.startswith("Error: cannot connect"))
    assert result.exit_code != 0 and result.output.strip() == quoted.strip()

    # step 4's stop
    summary = json.loads((work / "runs" / "over" / "summary.json").read_text())
    assert not summary["completed"] and summary["outcome"] == "failure" and summary["failure_kind"] == "stop_rule"
    quoted = next(t for t in texts if t.startswith("stop condition:"))
    assert summary["stop_reason"] in quoted


def test_results_match_the_page(tutorial):
    work, _, _ = tutorial
    runs = work / "runs"
    # the saved configuration reproduces the run bit for bit
    assert (runs / "again" / "signals.csv").read_bytes() == (runs / "damped" / "signals.csv").read_bytes()
    # --config file < --set < flags: 1 s (flag over the file's 2 s) with the file's damping
    saved = (runs / "heavy-config.yaml").read_text()
    assert "duration: 1.0" in saved and "damping: 0.5" in saved
    # --set length=2 made the pendulum longer, so slower: period 2π√(L/g)
    long_run = _columns(runs / "long" / "signals.csv")
    assert _period(long_run["t"], long_run["pend.theta"]) == pytest.approx(2 * math.pi * math.sqrt(2 / 9.81), rel=0.01)


def test_bank_periods(tutorial):
    work, _, _ = tutorial
    cols = _columns(work / "runs" / "bank" / "signals.csv")
    theta0 = 0.2
    for i, length in enumerate((0.5, 1.0, 1.5)):
        expected = 2 * math.pi * math.sqrt(length / 9.81) * (1 + theta0 ** 2 / 16)   # finite-amplitude correction
        assert _period(cols["t"], cols[f"p{i}/pend.theta"]) == pytest.approx(expected, rel=0.005), f"p{i}"
