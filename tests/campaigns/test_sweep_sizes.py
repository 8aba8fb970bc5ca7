"""Campaign sizes checked before anything is allocated: run i's sample is drawn when run i is submitted
(never N samples up front), the run queue is a generator fed to the back end in a bounded window, and an
N whose records could not be held is refused at once with the estimate of its memory and time."""

from __future__ import annotations

import textwrap
import time
from concurrent.futures import Future

import pytest
from click.testing import CliRunner

from snakesim.campaigns.campaign import RECORD_BYTES, prepare, run_campaign
from snakesim.campaigns.dispersions import Samples, load_dispersions, sample, sample_run
from snakesim.campaigns.runner import SceneSpec
from snakesim.framework import ConfigError
from snakesim.framework.cli import cli, install_plugin_cli

DISP = """
seed: 5
dispersions:
  components.pend.params.theta0: {dist: uniform, low: 0.1, high: 0.3}
  components.pend.params.length: {dist: grid, values: [1.0, 1.5]}
"""
LHS = DISP + "  damping: {dist: latin_hypercube, low: 0.0, high: 0.1}\n"


@pytest.fixture
def disp(tmp_path):
    def make(text=DISP):
        p = tmp_path / "d.yaml"
        p.write_text(textwrap.dedent(text))
        return p
    return make


def test_a_trillion_runs_are_refused_at_once_with_the_estimate(disp, tmp_path):
    install_plugin_cli()
    t0 = time.perf_counter()
    r = CliRunner().invoke(cli, ["sweep", "pendulum", "--dispersions", str(disp()), "-n", str(10**12),
                                 "--duration", "1", "--out", str(tmp_path / "o"), "--quiet"])
    assert time.perf_counter() - t0 < 30
    assert r.exit_code != 0 and "Traceback" not in r.output, r.output
    out = " ".join(r.output.split())
    assert "1000000000000 runs" in out and "TB" in out and "of CPU time" in out and "runs fit" in out, out
    assert not (tmp_path / "o").exists()


def test_the_bound_follows_the_memory_limit(disp, monkeypatch):
    monkeypatch.setenv("SNAKESIM_MEMORY_LIMIT", str(100 * RECORD_BYTES))
    assert prepare(SceneSpec("pendulum"), str(disp()), 100).n == 100
    with pytest.raises(ConfigError, match="at most 100 runs fit"):
        prepare(SceneSpec("pendulum"), str(disp()), 101)


def test_samples_are_drawn_when_asked_and_equal_the_run_alone(disp):
    df = load_dispersions(disp())
    t0 = time.perf_counter()
    s = Samples(df, 10**9, seed=2)          # nothing drawn
    assert len(s) == 10**9 and time.perf_counter() - t0 < 1
    assert s[10**9 - 1] == sample_run(df, 10**9 - 1, 2)
    assert s[7] == sample_run(df, 7, 2) and s[7]["components.pend.params.length"] == 1.5
    small = sample(df, 6, seed=2)
    assert [row["components.pend.params.length"] for row in s[:6]] == [r["components.pend.params.length"]
                                                                        for r in small]
    assert [row["components.pend.params.theta0"] for row in s[:6]] == pytest.approx(
        [r["components.pend.params.theta0"] for r in small], rel=1e-15)


def test_a_latin_hypercube_over_too_many_runs_is_refused_before_it_is_drawn(disp, monkeypatch):
    df = load_dispersions(disp(LHS))
    s = Samples(df, 8)
    assert sorted(int(row["damping"] / 0.1 * 8) for row in s) == list(range(8))    # one a stratum
    monkeypatch.setenv("SNAKESIM_MEMORY_LIMIT", "1e6")
    with pytest.raises(ConfigError, match="Latin-hypercube design would take"):
        Samples(df, 10**6)
    with pytest.raises(ConfigError, match="drawing every sample would take"):
        sample(df, 10**6)


class _Done:
    """A back end that records what it is given and returns each run's record at once."""

    slots = 2
    description = "test"

    def __init__(self):
        self.submitted = []
        self.executor = self

    def submit(self, fn, task):
        self.submitted.append(task.index)
        f = Future()
        f.set_result({"run": task.index, "parameters": dict(task.parameters), "status": "ok", "outcome": "success",
                      "completed": True, "metrics": {}, "session_reused": False})
        return f

    def restart(self):
        pass


def test_a_huge_campaign_feeds_the_back_end_in_a_bounded_window(disp, tmp_path):
    plan = prepare(SceneSpec("pendulum"), str(disp()), 10**6)
    backend = _Done()
    t0 = time.perf_counter()
    res = run_campaign(plan, tmp_path / "o", backend, quiet=True, stop_after=5)
    assert time.perf_counter() - t0 < 10
    assert backend.submitted == [0, 1, 2, 3, 4] and res["ran"] == 5 and res["table"].num_rows == 5
    # resumed: the recorded runs are skipped, the next ones drawn
    backend = _Done()
    run_campaign(plan, tmp_path / "o", backend, quiet=True, stop_after=3)
    assert backend.submitted == [5, 6, 7]
