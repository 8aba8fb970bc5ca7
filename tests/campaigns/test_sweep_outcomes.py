"""A sweep records each run's outcome and failure kind, and its exit status says whether any run failed.

The scene: the pendulum released at 0.2 rad with a success stop (it swings through the bottom) and the
failure rule "over the top" (|θ| > 3.2 rad); a grid on its initial rate decides which ends it: at 0 or
0.5 rad/s it swings down (success), at 12 rad/s its energy ½ω0² = 72 J/kg·m² is past the 2g/L = 19.6
needed to go over (failure).
"""

from __future__ import annotations

import csv
import json
import textwrap

from click.testing import CliRunner

from snakesim.campaigns.runner import RunTask, SceneSpec, execute
from snakesim.framework.cli import cli, install_plugin_cli
from snakesim.framework.outcomes import SWEEP_RUN_FAILED

SCENE = """
sim: {duration: 3.0, dt: 0.01, integrator: rk4}
components:
  pend: {type: pendulum, params: {length: 1.0, theta0: 0.2}}
record: [pend.theta]
stop:
  - {signal: pend.theta, below: 0.0, outcome: success, reason: "swung through the bottom"}
  - {signal: pend.theta, abs_above: 3.2, reason: "went over the top"}
"""


def _files(tmp_path, omegas):
    scene = tmp_path / "swing.yaml"
    scene.write_text(textwrap.dedent(SCENE))
    disp = tmp_path / "omega.yaml"
    disp.write_text(f"dispersions:\n  components.pend.params.omega0: {{dist: grid, values: {list(omegas)}}}\n")
    return scene, disp


def _sweep(tmp_path, omegas, name):
    install_plugin_cli()
    scene, disp = _files(tmp_path, omegas)
    out = tmp_path / name
    r = CliRunner().invoke(cli, ["sweep", str(scene), "--dispersions", str(disp), "-n", str(len(omegas)),
                                 "--out", str(out), "--workers", "1", "--no-plots", "--quiet"])
    rows = sorted((json.loads(line) for line in (out / "runs.jsonl").read_text().splitlines()),
                  key=lambda rec: rec["run"])
    return r, rows, out


def test_a_sweep_with_a_failed_run_records_each_outcome_and_exits_non_zero(tmp_path):
    r, rows, out = _sweep(tmp_path, [0.0, 12.0], "mixed")
    assert r.exit_code == SWEEP_RUN_FAILED, r.output
    assert [(x["status"], x["outcome"], x["failure_kind"]) for x in rows] == [
        ("ok", "success", None), ("stopped", "failure", "stop_rule")]
    assert "swung through the bottom" in rows[0]["stop_reason"] and not rows[0]["completed"]
    assert "went over the top" in rows[1]["reason"]
    with open(out / "results.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert [(x["outcome"], x["failure_kind"]) for x in table] == [("success", ""), ("failure", "stop_rule")]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failed"] == 1 and summary["by_failure_kind"] == {"stop_rule": 1}
    assert "1 of 2 runs not a success" in r.stderr


def test_a_sweep_whose_runs_all_succeed_exits_0(tmp_path):
    r, rows, _ = _sweep(tmp_path, [0.0, 0.5], "clean")
    assert r.exit_code == 0, r.output
    assert [x["outcome"] for x in rows] == ["success", "success"]


def test_numerical_failures_are_recorded_as_diverged_with_their_kind():
    """A 2-mass chain at k = 1e6 N/m, 10 ms RK4 steps (ω h = 14, past 2√2): the state overflows."""
    task = RunTask(index=0, scene=SceneSpec("mass-spring-chain", sim=(("duration", 1.0), ("dt", 0.01))),
                   sets=("n=2", "k=1e6"))
    rec = execute(task)
    assert (rec["status"], rec["outcome"], rec["failure_kind"]) == ("diverged", "failure", "non_finite")
    ok = execute(RunTask(index=1, scene=SceneSpec("pendulum", sim=(("duration", 0.1),)), sets=()))
    assert (ok["status"], ok["outcome"], ok["failure_kind"], ok["completed"]) == ("ok", "success", None, True)
