"""Campaigns end to end on the pendulum: local pool vs Dask LocalCluster, failures, resume, 1 vs 2 workers.

One dispersion file, N = 6: random damping and theta0, and a 3 x 2 grid of
length x omega0 in which length = -1 fails to build (error) and omega0 = 12
rad/s sends the pendulum over the top (the scene's stop condition: stopped).
"""

from __future__ import annotations

import json
import shutil
import textwrap

import pytest

from snakesim.campaigns.backends import dask_local, local_pool
from snakesim.campaigns.campaign import prepare, run_campaign
from snakesim.campaigns.report import summarize
from snakesim.campaigns.results import RECORDS, TIMING_COLUMNS
from snakesim.campaigns.runner import RunTask, SceneSpec, execute

N = 6
DISPERSIONS = """
seed: 21
dispersions:
  damping: {dist: uniform, low: 0.01, high: 0.2}
  components.pend.params.theta0: {dist: truncated_normal, mean: 0.2, std: 0.1, low: 0.05, high: 0.4}
  components.pend.params.length: {dist: grid, values: [1.0, -1.0, 1.2]}
  components.pend.params.omega0: {dist: grid, values: [0.0, 12.0]}
metrics:
  theta_final: {signal: pend.theta, reduce: final}
  omega_peak: {signal: pend.omega, reduce: max_abs}
curves:
  - {x: components.pend.params.theta0, y: omega_peak}
"""
SCENE = SceneSpec("pendulum", sim=(("duration", 1.0),))


@pytest.fixture(scope="module")
def plan(tmp_path_factory):
    f = tmp_path_factory.mktemp("disp") / "pendulum-dispersions.yaml"
    f.write_text(textwrap.dedent(DISPERSIONS).lstrip("\n"))
    return prepare(SCENE, str(f), N)


def _rows(table):
    """The table without the columns that differ between executions (timing, which worker)."""
    return [{k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in table.to_pylist()]


@pytest.fixture(scope="module")
def pool_run(plan, tmp_path_factory):
    out = tmp_path_factory.mktemp("pool")
    with local_pool(2) as backend:
        res = run_campaign(plan, out, backend, quiet=True)
    return out, res


@pytest.mark.slow
def test_failing_runs_are_recorded_with_their_reason_and_the_campaign_goes_on(plan, pool_run):
    out, res = pool_run
    rows = res["table"].to_pylist()
    assert [r["run"] for r in rows] == list(range(N))
    status = [r["status"] for r in rows]
    assert status == ["ok", "stopped", "error", "error", "ok", "stopped"]
    assert "length" in rows[2]["reason"] and "greater than 0" in rows[2]["reason"]
    assert "pendulum went over the top" in rows[1]["reason"]
    assert rows[0]["theta_final"] is not None and rows[2]["theta_final"] is None
    assert (out / "results.parquet").exists() and (out / "results.csv").exists()
    summary = summarize(res["table"], out, plots=True, curves=plan.dispersions.curves)
    assert summary["by_status"] == {"error": 2, "ok": 2, "stopped": 2}
    assert (out / "hist.png").exists() and (out / "success_by_parameter.png").exists()
    assert "curves.png" in summary["plots"] and (out / "curves.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (out / "scatter.png").exists() and (out / "sensitivity.csv").exists()


@pytest.mark.slow
def test_dask_local_cluster_gives_the_same_table_as_the_local_pool(plan, pool_run, tmp_path):
    with dask_local(2) as backend:
        res = run_campaign(plan, tmp_path, backend, quiet=True)
    assert _rows(res["table"]) == _rows(pool_run[1]["table"])
    assert len({r["worker"] for r in res["table"].to_pylist()}) == 2


def test_resume_runs_only_the_missing_runs_and_one_worker_matches_two(plan, pool_run, tmp_path):
    out, res = pool_run
    shutil.copy(out / "campaign.json", tmp_path / "campaign.json")
    lines = (out / RECORDS).read_text().splitlines(keepends=True)
    done = {json.loads(line)["run"] for line in lines[:3]}
    # an interrupted campaign: three finished runs, then a line torn by the kill
    (tmp_path / RECORDS).write_text("".join(lines[:3]) + lines[3][: len(lines[3]) // 2])
    with local_pool(1) as backend:
        resumed = run_campaign(plan, tmp_path, backend, quiet=True)
    assert resumed["resumed"] and resumed["ran"] == N - 3
    recs = [json.loads(line) for line in (tmp_path / RECORDS).read_text().splitlines()]
    assert len(recs) == N and {r["run"] for r in recs[3:]} == set(range(N)) - done
    assert _rows(resumed["table"]) == _rows(res["table"])     # 1 worker (+ resume) == 2 workers


def test_resuming_with_other_arguments_is_refused(plan, pool_run, tmp_path):
    from dataclasses import replace

    from snakesim.campaigns.results import CampaignError

    out, _ = pool_run
    shutil.copy(out / "campaign.json", tmp_path / "campaign.json")
    with pytest.raises(CampaignError, match="holds a different campaign \\(seed differ"):
        run_campaign(replace(plan, seed=99), tmp_path, backend=None, quiet=True)


def test_a_run_past_its_wall_time_limit_is_recorded_as_timeout_and_sessions_are_reused(plan):
    slow = SceneSpec("pendulum", sim=(("duration", 30.0), ("integrator", "dopri5"), ("dt", 0.0005)))
    rec = execute(RunTask(index=0, scene=slow, sets=(), timeout_s=0.2))
    assert rec["status"] == "timeout" and "wall-time limit 0.2 s" in rec["reason"]
    assert rec["run_wall_s"] < 3
    task = plan.task(0, None, False, None)
    first, again = execute(task), execute(task)
    assert not first["session_reused"] and again["session_reused"]
    assert first["metrics"] == again["metrics"] and first["status"] == again["status"] == "ok"
