"""A run's --out folder under faults (framework/run_files.py, framework/recorder.py), with real processes:

* two runs started together on one folder: exactly one writes it, the other refuses naming the first;
  the folder holds one whole run (no torn rows);
* a run killed (SIGKILL) keeps its rows up to about a second before the kill (the timed flush), its
  summary says the run is incomplete, replay says so, and the next run takes the dead run's claim over;
* the timed flush writes the same bytes as writing the recording at once;
* a claim held by a live process is refused, one left by a dead process taken over.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from snakesim.framework import SnakesimError
from snakesim.framework import recorder as recorder_module
from snakesim.framework.run_files import INCOMPLETE, LOCK_FILE, prepare_out_dir, release_out_dir
from snakesim.framework.session import load_session

SNAKESIM = [sys.executable, "-c", "from snakesim.framework.cli import main; main()"]


def run_cli(*args) -> subprocess.Popen:
    return subprocess.Popen([*SNAKESIM, "run", *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def rows_of(path: Path) -> list[list[str]]:
    with open(path, newline="") as fh:
        return list(csv.reader(fh))


def last_time(path: Path) -> float:
    """t of the last whole row of a signals.csv being written (−1 before any)."""
    try:
        rows = rows_of(path)
        return float(rows[-1][0]) if len(rows) > 1 else -1.0
    except (OSError, ValueError, IndexError):
        return -1.0


@pytest.mark.slow
def test_two_runs_on_one_folder_one_refuses_naming_the_other(tmp_path):
    out = tmp_path / "run"
    # --realtime: each run holds the folder for 2 s, so the two overlap whatever their start-up times
    a, b = (run_cli("pendulum", "--duration", 2, "--realtime", "--out", out, "--overwrite", "--quiet")
            for _ in range(2))
    results = [(p.wait(timeout=120), p.stderr.read()) for p in (a, b)]
    codes = sorted(code for code, _ in results)
    assert codes[0] == 0 and codes[1] != 0, results
    refused = next(err for code, err in results if code != 0)
    winner = a if results[0][0] == 0 else b
    assert "another snakesim run is writing there" in refused and f"pid {winner.pid}" in refused, refused
    rows = rows_of(out / "signals.csv")
    assert {len(r) for r in rows} == {len(rows[0])}                  # no torn or interleaved line
    assert len(rows) - 1 == 2001 and float(rows[-1][0]) == pytest.approx(2.0)
    assert json.loads((out / "summary.json").read_text())["completed"] is True
    assert not (out / LOCK_FILE).exists()                            # the claim is released at the end


@pytest.mark.slow
def test_a_killed_run_keeps_its_rows_says_it_is_incomplete_and_its_claim_is_taken_over(tmp_path):
    out = tmp_path / "run"
    p = run_cli("pendulum", "--duration", 60, "--realtime", "--out", out, "--quiet")
    signals = out / "signals.csv"
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline and last_time(signals) < 3.0:    # until rows past t = 3 s are flushed
        time.sleep(0.2)
    p.send_signal(signal.SIGKILL)
    p.wait(timeout=30)
    rows = rows_of(signals)
    assert {len(r) for r in rows} == {len(rows[0])}
    t = np.array([float(r[0]) for r in rows[1:]])
    # 3 s kept, flushed in steps of about a second (FLUSH_SECONDS + the 0.2 s poll): 8192-row chunks alone
    # would first show rows at t = 8.2 s
    assert 3.0 <= t[-1] < 5.0 and np.all(np.diff(t) > 0)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["outcome"] == INCOMPLETE and summary["completed"] is False and summary["pid"] == p.pid

    from snakesim.components.viz.replay import replay
    from snakesim.components.viz.target import VizTarget
    report = replay(out, VizTarget("save", str(tmp_path / "replay.rrd")))
    assert any("is incomplete" in n and f"{len(t)} rows" in n for n in report.notes), report.notes

    # the dead run's claim is taken over by the next run (with --overwrite: the folder holds its files)
    assert (out / LOCK_FILE).exists()
    q = run_cli("pendulum", "--duration", 0.5, "--out", out, "--overwrite", "--quiet")
    assert q.wait(timeout=120) == 0, q.stderr.read()
    assert json.loads((out / "summary.json").read_text())["completed"] is True


def test_the_timed_flush_writes_what_writing_at_once_does(tmp_path, monkeypatch):
    monkeypatch.setattr(recorder_module, "FLUSH_SECONDS", 0.0)      # a flush after every row
    s = load_session("pendulum", sim_overrides={"duration": 0.5})
    s.run(out_dir=tmp_path / "streamed")
    streamed = (tmp_path / "streamed" / "signals.csv").read_bytes()
    monkeypatch.setattr(recorder_module, "FLUSH_SECONDS", 1e9)
    s = load_session("pendulum", sim_overrides={"duration": 0.5})
    result = s.run()
    result.log.write_csv(tmp_path / "once.csv")
    assert streamed == (tmp_path / "once.csv").read_bytes()
    assert streamed.count(b"\n") == 502


def test_a_claim_by_a_live_process_is_refused_and_one_by_a_dead_process_taken_over(tmp_path):
    import socket

    out = tmp_path / "run"
    out.mkdir()
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        (out / LOCK_FILE).write_text(json.dumps({"pid": sleeper.pid, "host": socket.gethostname(),
                                                 "started": "2026-11-27T12:00:00+00:00"}))
        with pytest.raises(SnakesimError, match=f"another snakesim run is writing there \\(pid {sleeper.pid} on "):
            prepare_out_dir(out, overwrite=True)
    finally:
        sleeper.kill()
        sleeper.wait()
    prepare_out_dir(out, overwrite=True)                             # its process is gone: taken over
    assert json.loads((out / LOCK_FILE).read_text())["pid"] == os.getpid()
    prepare_out_dir(out, overwrite=True)                             # ours already: re-entrant
    release_out_dir(out)
    assert not (out / LOCK_FILE).exists()


@pytest.mark.parametrize("links", [True, False], ids=["hard-links", "no-hard-links"])
def test_a_claim_appears_with_its_holder_and_leaves_no_scratch(tmp_path, monkeypatch, links):
    # the claim is linked into place whole, so a second run never reads it empty (the race that once left a
    # refusal without the holder's pid); where os.link is refused (a file system without hard links), an
    # exclusive create still claims the folder
    import errno

    out = tmp_path / "run"
    out.mkdir()
    seen = []
    real_link = os.link

    def link(src, dst):
        seen.append(json.loads(Path(src).read_text())["pid"])        # whole before it becomes the claim
        if not links:
            raise PermissionError(errno.EPERM, "Operation not permitted")
        return real_link(src, dst)

    monkeypatch.setattr(os, "link", link)
    prepare_out_dir(out, overwrite=True)
    assert seen == [os.getpid()]
    assert json.loads((out / LOCK_FILE).read_text())["pid"] == os.getpid()
    assert sorted(p.name for p in out.iterdir()) == [LOCK_FILE]       # the private copy is gone
    release_out_dir(out)
    assert not any(out.iterdir())
