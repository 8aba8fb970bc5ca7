"""``snakesim sweep`` on a full or read-only disk: every file it writes (campaign.json, runs.jsonl,
results.parquet/.csv, sensitivity.csv, the plots, summary.json) fails with a clear error naming the file
and the cause, a non-zero exit and no partial file (framework/output_files.py).

The full disk is simulated independently of the file system (the one write of every output file raises
ENOSPC at the Nth write); the read-only cases are real (a path through a regular file, a file name taken
by a folder). A finished campaign is copied and resumed, so the table and report are written again
without running anything.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import textwrap
from pathlib import Path

import pytest
from click.testing import CliRunner

from snakesim.framework import output_files
from snakesim.framework.cli import cli, install_plugin_cli

SCENE = """
sim: {duration: 0.05, dt: 0.01, integrator: rk4}
components:
  pend: {type: pendulum, params: {length: 1.0, theta0: 0.2}}
record: [pend.theta]
"""
DISPERSIONS = """
seed: 3
dispersions:
  components.pend.params.theta0: {dist: uniform, low: 0.1, high: 0.3}
metrics:
  theta_final: {signal: pend.theta, reduce: final}
"""
N = 4


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("sweep")
    (d / "swing.yaml").write_text(textwrap.dedent(SCENE))
    (d / "disp.yaml").write_text(textwrap.dedent(DISPERSIONS))
    return d


def sweep(files, out, *extra):
    install_plugin_cli()
    return CliRunner().invoke(cli, ["sweep", str(files / "swing.yaml"), "--dispersions", str(files / "disp.yaml"),
                                    "-n", str(N), "--out", str(out), "--workers", "1", "--quiet", *map(str, extra)])


@pytest.fixture(scope="module")
def finished(files):
    out = files / "finished"
    r = sweep(files, out, "--save-runs")
    assert r.exit_code == 0, r.output
    return out


def full_disk_at(monkeypatch, n: int) -> list[str]:
    names: list[str] = []
    real = output_files._write_all

    def write(fh, data):
        name = os.path.basename(fh.name)
        names.append(name[1:].rsplit(".", 2)[0] if name.endswith(".tmp") else name)   # .NAME.PID.tmp -> NAME
        if len(names) == n:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(fh, data)

    monkeypatch.setattr(output_files, "_write_all", write)
    return names


def no_partial_files(out: Path) -> None:
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp")]


#: what a resumed, finished campaign writes, in order
REPORT = ["results.parquet", "results.csv", "sensitivity.csv", "hist.png", "scatter.png",
          "success_by_parameter.png", "summary.json"]


@pytest.mark.parametrize("n", range(1, len(REPORT) + 1))
def test_a_full_disk_at_each_report_file_is_named_and_leaves_the_old_one(finished, tmp_path, monkeypatch, n):
    out = tmp_path / "c"
    shutil.copytree(finished, out)
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    names = full_disk_at(monkeypatch, n)
    r = sweep(finished.parent, out, "--save-runs")
    assert names[:n] == REPORT[:n]
    assert r.exit_code not in (0, 20) and "Traceback" not in r.output, r.output
    assert f"cannot write {out / REPORT[n - 1]}: No space left on device" in r.output, r.output
    no_partial_files(out)
    assert (out / REPORT[n - 1]).read_bytes() == before[REPORT[n - 1]]       # the earlier file, whole


def test_a_full_disk_at_the_first_record_leaves_no_torn_line(files, tmp_path, monkeypatch):
    out = tmp_path / "fresh"
    names = full_disk_at(monkeypatch, 2)            # campaign.json, then the first runs.jsonl line
    r = sweep(files, out)
    assert names[:2] == ["campaign.json", "runs.jsonl"]
    assert r.exit_code not in (0, 20) and f"cannot write {out / 'runs.jsonl'}: No space left" in r.output, r.output
    assert (out / "runs.jsonl").read_bytes() == b""
    json.loads((out / "campaign.json").read_text())
    no_partial_files(out)


def test_a_full_disk_at_the_campaign_file(files, tmp_path, monkeypatch):
    out = tmp_path / "fresh"
    full_disk_at(monkeypatch, 1)
    r = sweep(files, out)
    assert r.exit_code not in (0, 20) and f"cannot write {out / 'campaign.json'}: No space left" in r.output
    assert list(out.iterdir()) == []


def test_an_out_folder_through_a_regular_file_is_refused_before_anything_runs(files, tmp_path):
    (tmp_path / "plain").write_text("x")
    r = sweep(files, tmp_path / "plain" / "c")
    assert r.exit_code != 0 and "Traceback" not in r.output
    assert f"--out {tmp_path / 'plain' / 'c'}: cannot write there (Not a directory)" in r.output, r.output


def test_a_results_file_that_cannot_be_replaced_is_named(finished, tmp_path):
    out = tmp_path / "c"
    shutil.copytree(finished, out)
    (out / "results.parquet").unlink()
    (out / "results.parquet").mkdir()               # a folder in the way: os.replace fails
    r = sweep(finished.parent, out, "--save-runs")
    assert r.exit_code not in (0, 20) and f"cannot write {out / 'results.parquet'}: Is a directory" in r.output
    no_partial_files(out)
