"""Failures say so: every way a run ends, through the real command line (click's runner, standalone mode:
``sys.exit`` codes are what a shell sees), its exit code from the one table (framework/outcomes.py) and
its summary's ``outcome`` and ``failure_kind``.

Scenes are the smallest that reach each ending for a physical reason: the pendulum (a quarter swing,
a rule), a stiff spring chain past RK4's bound (overflow), the robot scenes for the contact guard,
the mobility monitor and the blow-up guard (built from numba's disk cache: ~1 s each).
"""

from __future__ import annotations

import json
import math
import re
import textwrap
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from snakesim.framework import Component, Input, Output, Params
from snakesim.framework import cli as cli_mod
from snakesim.framework.cli import cli
from snakesim.framework.outcomes import (FAILURE_KINDS, INTERRUPTED, RETIRED_BLOW_UP, SWEEP_RUN_FAILED, check_stop,
                                        exit_code_of, table_markdown)

ROOT = Path(__file__).resolve().parents[2]
PENDULUM = """
sim: {{duration: {duration}, dt: 0.01, integrator: rk4}}
components:
  pend: {{type: pendulum, params: {{length: 1.0, theta0: 0.2, omega0: {omega0}}}}}
record: [pend.theta]
stop:
{stops}
"""
G = 9.81


def invoke(*args, env=None):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False, env=env)


def pendulum(tmp_path, stops, duration=2.0, omega0=0.0, name="scene.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(PENDULUM).format(duration=duration, omega0=omega0,
                                                     stops=textwrap.indent(textwrap.dedent(stops).strip(), "  ")))
    return path


def scene_file(tmp_path, name: str, text: str) -> Path:
    """A scene for the command line: the text, dedented, in tmp_path/name."""
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


# -- the table ----------------------------------------------------------------------------------------

def test_exit_codes_are_distinct_and_clear_of_click_the_retired_code_and_signals():
    codes = [code for code, _ in FAILURE_KINDS.values()]
    assert len(set(codes)) == len(codes)
    # 1: click's error, 2: click's usage error, 3: the old single blow-up code, 126/127: the shell's,
    # 128 + N: a signal; 0 is success
    assert all(3 < c < 126 for c in codes) and RETIRED_BLOW_UP not in codes
    assert SWEEP_RUN_FAILED not in codes and 3 < SWEEP_RUN_FAILED < 126


def test_readme_and_architecture_quote_the_table_from_the_code():
    table = table_markdown()
    for doc in ("README.md", "docs/architecture.md"):
        assert table in (ROOT / doc).read_text(), f"{doc}: paste framework.outcomes.table_markdown()"


def test_a_stop_checks_its_outcome_and_kind():
    assert check_stop("success", None, "guard") is None
    assert check_stop("failure", None, "guard") == "guard"
    assert check_stop("failure", "mobility", "guard") == "mobility"
    with pytest.raises(ValueError, match="unknown failure kind 'interrupted'"):
        check_stop("failure", INTERRUPTED, "guard")          # the simulator's, for signals only
    with pytest.raises(ValueError, match="'success' or 'failure'"):
        check_stop("maybe", None, "guard")
    with pytest.raises(ValueError, match="unknown failure kind 'oops'"):
        check_stop("failure", "oops", "guard")
    with pytest.raises(ValueError, match="no failure kind"):
        check_stop("success", "guard", "guard")


# -- successes exit 0 ---------------------------------------------------------------------------------

def test_duration_reached_is_a_success(tmp_path):
    out = tmp_path / "o"
    r = invoke("run", "pendulum", "--duration", "0.05", "--quiet", "--out", out)
    assert r.exit_code == 0, r.output
    sm = summary(out)
    assert sm["outcome"] == "success" and sm["failure_kind"] is None and sm["completed"] is True


def test_a_success_stop_exits_0_and_says_it_did_not_run_its_duration(tmp_path):
    """Released at 0.2 rad, the pendulum passes the bottom after a quarter period, (π/2)√(L/g) lengthened by
    θ0²/16 at this amplitude; the scene calls that a success."""
    scene = pendulum(tmp_path, '- {signal: pend.theta, below: 0.0, outcome: success, reason: "reached the bottom"}')
    out = tmp_path / "o"
    r = invoke("run", scene, "--out", out)
    assert r.exit_code == 0, r.output
    sm = summary(out)
    assert sm["outcome"] == "success" and sm["failure_kind"] is None
    assert sm["completed"] is False and "reached the bottom" in sm["stop_reason"]
    quarter = math.pi / 2 * math.sqrt(1.0 / G) * (1 + 0.2 ** 2 / 16)
    assert quarter <= sm["t_end_s"] <= quarter + 0.01 + 1e-3     # the first step past the crossing
    assert "failure" not in r.stderr


def test_a_failure_outranks_a_success_at_the_same_tick(tmp_path):
    scene = pendulum(tmp_path, '''
        - {signal: pend.theta, above: 0.1, outcome: success, reason: "high enough"}
        - {signal: pend.theta, above: 0.1, reason: "too high"}
    ''')
    out = tmp_path / "o"
    r = invoke("run", scene, "--quiet", "--out", out)
    assert r.exit_code == exit_code_of("stop_rule")
    sm = summary(out)
    assert sm["t_end_s"] == 0.0 and "too high" in sm["stop_reason"] and sm["failure_kind"] == "stop_rule"


def test_a_bad_outcome_names_the_file_line_key_and_value(tmp_path):
    scene = pendulum(tmp_path, '- {signal: pend.theta, below: 0.0, outcome: win}')
    r = invoke("run", scene)
    assert r.exit_code == 1
    assert re.search(rf"{re.escape(str(scene))}:\d+: stop\[0\]\.outcome: Input should be 'success' or 'failure' "
                     r"\(got 'win'\)", r.output), r.output


# -- each failure kind, its code ---------------------------------------------------------------------------

class RaisesParams(Params):
    at: float = 0.05        # s


class Raises(Component[RaisesParams]):
    """A component whose evaluation fails numerically at t >= at (a singular solve)."""

    type_name = "test_raises_linalg"
    Params = RaisesParams
    u = Input(unit=None)
    y = Output(unit=None, feedthrough=("u",))

    def output(self, t, x, u, y):
        if t >= self.p.at:
            np.linalg.inv(np.zeros((2, 2)))
        y.y[...] = u.u


class Goal(Component[RaisesParams]):
    """A sink that ends the run as a success at t >= at (an evaluation reaching its goal)."""

    type_name = "test_goal"
    Params = RaisesParams
    is_sink = True
    u = Input(unit=None)

    def update(self, t, xd, u):
        if t >= self.p.at:
            self.stop("goal reached", outcome="success")


def _with_test_components(monkeypatch):
    """The CLI's registry with this file's components added (the built-ins have none that stops on success
    or raises)."""
    from snakesim.framework.registry import build_registry

    reg = build_registry()              # a fresh one: the process-wide registry stays as installed
    for cls in (Raises, Goal):
        reg.add_component(cls)
    monkeypatch.setattr(cli_mod, "default_registry", lambda: reg)


def test_a_components_success_stop_exits_0(tmp_path, monkeypatch):
    _with_test_components(monkeypatch)
    scene = scene_file(tmp_path, "goal.yaml", """
        sim: {duration: 1.0, dt: 0.01}
        components:
          pend: {type: pendulum}
          goal: {type: test_goal, params: {at: 0.1}}
        connections: [pend.theta -> goal.u]
    """)
    out = tmp_path / "o"
    r = invoke("run", scene, "--quiet", "--out", out)
    assert r.exit_code == 0, r.output
    sm = summary(out)
    assert sm["outcome"] == "success" and sm["failure_kind"] is None and not sm["completed"]
    # asked in its update at t = 0.1 s (after that tick's stop checks): the run ends at the next tick
    assert sm["stop_reason"] == "goal: goal reached at t = 0.11 s"


def _numerical(tmp_path, monkeypatch):
    _with_test_components(monkeypatch)
    scene = scene_file(tmp_path, "raises.yaml", """
        sim: {duration: 1.0, dt: 0.01}
        components:
          pend: {type: pendulum}
          bad: {type: test_raises_linalg}
        connections: [pend.theta -> bad.u]
        record: [bad.y]
    """)
    return [scene]


def _mobility(tmp_path, monkeypatch):
    # a robot lying along x in zero gravity: its axis is 90° from the vertical, past the 60° limit at once
    scene = scene_file(tmp_path, "tilted.yaml", """
        sim: {duration: 0.1, dt: 0.001, integrator: rk4}
        components:
          robot: {type: multibody, params: {design: eels-1.0, modules: 1, gravity: [0.0, 0.0, 0.0]}}
          monitor: {type: mobility_monitor, rate: 100}
        connections:
          - robot.link_rotations -> monitor.link_rotations
          - robot.link_poses -> monitor.link_poses
          - robot.link_velocities -> monitor.link_velocities
    """)
    return [scene]


CASES = {
    # a rule of the scene's: the pendulum released at 0.2 rad passes the bottom
    "stop_rule": lambda tmp, mp: [pendulum(tmp, '- {signal: pend.theta, below: 0.0, reason: "fell"}')],
    # the contact's depth guard: the robot placed 40 mm into the ice (max_depth 30 mm)
    "guard": lambda tmp, mp: ["contact-screw-drive", "--modules", "2", "--duration", "0.01",
                              "--set", "components.robot.params.base_position=[0,0,0.05]"],
    "mobility": _mobility,
    # RK4 at 20 ms on the default scene: ω h = 30 on the contact, the robot gains energy from nothing
    "blow_up": lambda tmp, mp: ["--integrator", "rk4", "--dt", "0.02", "--duration", "1"],
    # a spring chain at ω h = 14 (k = 1e6 N/m on 1 kg, 10 ms): no multibody, so it overflows
    "non_finite": lambda tmp, mp: ["mass-spring-chain", "--set", "n=2", "--set", "k=1e6", "--dt", "0.01",
                                   "--duration", "1", "--integrator", "rk4"],
    # dopri5 held to one sub-step per base step at a tolerance one step cannot meet
    "integrator": lambda tmp, mp: [pendulum(tmp, "[]", duration=0.5), "--set", "sim.integrator.name=dopri5",
                                   "--set", "sim.integrator.params={rtol: 1.0e-12, atol: 1.0e-14, max_substeps: 1}"],
    "numerical": _numerical,
    "memory_limit": lambda tmp, mp: ["pendulum", "--duration", "1000"],
}
MESSAGES = {
    "stop_rule": r"stop condition: fell at t = ", "guard": r"^contact: contact on screw link .* deep",
    "mobility": r"^monitor: mobility failure: .* tilted 90\.0 deg", "blow_up": r"^robot: blow-up in the step from t = ",
    "non_finite": r"non-finite", "integrator": r"^integrator dopri5 failed .*more than 1 sub-steps",
    "numerical": r"^component 'bad' failed at t = 0\.05 s: LinAlgError",
    "memory_limit": r"^recording reached the memory limit",
}


@pytest.mark.filterwarnings("ignore:overflow:RuntimeWarning", "ignore:invalid value:RuntimeWarning")
@pytest.mark.parametrize("kind", list(CASES))
def test_each_failure_kind_exits_with_its_code(kind, tmp_path, monkeypatch):
    from snakesim.framework.cli import install_plugin_cli

    install_plugin_cli()          # --modules
    env = None
    if kind == "memory_limit":
        env = {"SNAKESIM_MEMORY_LIMIT": "3e5"}        # the pendulum's 2 columns: ~2 chunks of rows fit
    args = CASES[kind](tmp_path, monkeypatch)
    out = tmp_path / "out"
    r = invoke("run", *args, "--out", out, env=env)
    assert r.exit_code == exit_code_of(kind), r.output
    sm = summary(out)
    assert sm["outcome"] == "failure" and sm["failure_kind"] == kind and sm["completed"] is False
    assert re.search(MESSAGES[kind], sm["stop_reason"]), sm["stop_reason"]
    assert f"failure ({kind}): exit status {exit_code_of(kind)}" in r.stderr


def test_the_blow_up_guard_fires_before_the_scene_rule_and_keeps_the_state_before_the_step(tmp_path):
    """The default scene at RK4 20 ms: the guard, not the scene's 'tail left the ground' (which ends this run
    at 0.66 s without it), ends the run, and keeps the state at the start of the step that gained the energy."""
    out = tmp_path / "o"
    r = invoke("run", "--integrator", "rk4", "--dt", "0.02", "--duration", "1", "--quiet", "--out", out)
    assert r.exit_code == exit_code_of("blow_up")
    sm = summary(out)
    m = re.search(r"step from t = ([\d.e+-]+) to ([\d.e+-]+) s: link '(\w+)'", sm["stop_reason"])
    assert m, sm["stop_reason"]
    t0, t1 = float(m.group(1)), float(m.group(2))
    assert t1 == pytest.approx(sm["t_end_s"]) and t1 - t0 == pytest.approx(0.02)
    assert sm["last_good_time_s"] == pytest.approx(t0)
    state = np.load(out / "last_good_state.npz")
    assert float(state["t"]) == pytest.approx(t0) and np.isfinite(state["X"]).all()
    rule = invoke("run", "--integrator", "rk4", "--dt", "0.02", "--duration", "1", "--quiet", "--out", tmp_path / "r",
                  "--set", "components.robot.params.blowup_guard.enabled=false")
    assert rule.exit_code == exit_code_of("stop_rule")
    assert summary(tmp_path / "r")["t_end_s"] > sm["t_end_s"]


def test_a_bad_guard_parameter_is_a_config_error():
    r = invoke("run", "robot-zero-g", "--duration", "0.01", "--set", "components.robot.params.blowup_guard.factor=0.5")
    assert r.exit_code == 1 and "blowup_guard.factor" in r.output and "greater than or equal to 1" in r.output
    r = invoke("run", "robot-zero-g", "--duration", "0.01", "--set", "components.robot.params.blowup_guard.floor=-1")
    assert r.exit_code == 1 and "blowup_guard.floor" in r.output and "greater than 0" in r.output
