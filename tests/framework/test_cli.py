"""The command line through click's test runner."""

from __future__ import annotations

import csv
import json

import pytest
from click.testing import CliRunner

from snakesim.framework.cli import cli
from snakesim.framework.session import load_session


@pytest.fixture
def invoke():
    runner = CliRunner()

    def run(*args):
        return runner.invoke(cli, [str(a) for a in args], catch_exceptions=False)

    return run


def test_run_writes_outputs(invoke, tmp_path):
    out = tmp_path / "out"
    r = invoke("run", "pendulum", "--duration", "0.1", "--dt", "0.01", "--out", out)
    assert r.exit_code == 0, r.output
    assert "duration reached" in r.stderr
    with open(out / "signals.csv") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t", "pend.theta", "pend.omega", "damper.tau"]
    assert len(rows) == 1 + 11
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"] == 10 and summary["dt_s"] == 0.01 and summary["completed"]
    assert load_session(out / "config.yaml").resolved.sim.dt == 0.01


def test_run_quiet_prints_nothing(invoke, tmp_path):
    r = invoke("run", "pendulum", "--duration", "0.01", "--quiet")
    assert r.exit_code == 0 and r.output == ""


def test_check_json(invoke, write_yaml):
    r = invoke("check", "pendulum", "--json")
    assert r.exit_code == 0, r.output
    rep = json.loads(r.stdout)
    assert sorted(rep["components"]) == ["damper", "pend"]
    assert rep["components"]["pend"]["continuous_states"] == 2
    assert rep["pruned"] == []
    assert rep["state_size"] == {"continuous": 2, "tangent": 2, "discrete": 0}
    assert rep["rates_hz"] == [] and rep["integrator"] == "rk4"

    path = write_yaml("""
        sim: {dt: 0.001}
        components:
          src: {type: sine}
          zoh: {type: zero_order_hold, rate: 50, params: {n: 1}}
          unused: {type: gain}
        connections:
          - src.y -> zoh.u, unused.u
        """)
    r = invoke("check", path, "--json")
    assert r.exit_code == 0, r.output
    rep = json.loads(r.stdout)
    assert rep["pruned"] == ["unused"]
    assert rep["rates_hz"] == [50.0] and rep["components"]["zoh"]["period_steps"] == 20
    assert rep["state_size"]["discrete"] == 1


def test_check_text(invoke):
    r = invoke("check", "mass-spring-chain", "--set", "n=3")
    assert r.exit_code == 0, r.output
    assert "5 components" in r.output and "pruned (outputs reach no state, recorder or sink): none" in r.output


def test_components_lists_the_registry(invoke):
    r = invoke("components")
    assert r.exit_code == 0
    for name in ("pendulum", "viscous_damper", "zero_order_hold", "point_mass", "spring_damper"):
        assert f"\n{name}  (" in "\n" + r.output
    ref = json.loads(invoke("components", "--json").stdout)
    assert [p["name"] for p in ref["pendulum"]["inputs"]] == ["tau"]
    assert {p["name"] for p in ref["pendulum"]["params"]} == {"length", "mass", "gravity", "theta0", "omega0"}


@pytest.mark.parametrize("flag", ["--dt", "--duration"])
def test_negative_step_is_a_clear_error(invoke, flag):
    r = invoke("run", "pendulum", flag, "-1")
    assert r.exit_code == 2
    assert f"Invalid value for '{flag}'" in r.output and "must be > 0, got -1" in r.output


def test_unknown_scene_lists_close_matches(invoke):
    r = invoke("run", "pendulm")
    assert r.exit_code == 1
    assert "no assembly 'pendulm'" in r.output and "Did you mean: pendulum" in r.output
    assert "Traceback" not in r.output


def test_config_error_is_reported_without_traceback(invoke):
    r = invoke("check", "pendulum", "--set", "dampin=0.1")
    assert r.exit_code == 1
    assert "Error: --set: dampin: 'dampin' is neither a top-level key" in r.output
    assert "did you mean damping" in r.output


def test_save_config_round_trips(invoke, tmp_path):
    cfg = tmp_path / "resolved.yaml"
    r = invoke("run", "pendulum", "--duration", "0.05", "--set", "damping=0.3", "--integrator", "dopri5",
               "--save-config", cfg, "--quiet")
    assert r.exit_code == 0, r.output
    s = load_session(cfg)
    assert s.plan.components["damper"].p.c == 0.3
    assert s.integrator.name == "dopri5" and s.resolved.sim.duration == 0.05
    assert s.plan.components["pend"].p.gravity == 9.81       # defaults are written out in full


@pytest.mark.filterwarnings("ignore:overflow:RuntimeWarning", "ignore:invalid value:RuntimeWarning")
def test_blow_up_exits_with_the_non_finite_code(invoke):
    """An explicit step far past the stiff chain's stability bound: the state overflows (the chain has no
    multibody, so no blow-up guard sees it first): failure kind non_finite and its exit code."""
    from snakesim.framework.outcomes import exit_code_of

    r = invoke("run", "mass-spring-chain", "--set", "n=2", "--set", "k=1e6", "--dt", "0.01", "--duration", "1",
               "--integrator", "rk4", "--quiet")
    assert r.exit_code == exit_code_of("non_finite")


def test_realtime_paces_simulated_time_to_the_wall_clock(tmp_path):
    """--realtime sleeps whenever simulation runs ahead, so wall time can never be
    shorter than simulated time: the real-time factor is at most 1 (a lower bound
    on wall time, which sleeping guarantees, not a speed target)."""
    import json as _json

    from click.testing import CliRunner

    from snakesim.framework.cli import cli

    out = tmp_path / "rt"
    res = CliRunner().invoke(cli, ["run", "pendulum", "--duration", "0.3", "--realtime", "--quiet", "--out", str(out)])
    assert res.exit_code == 0, res.output
    summary = _json.loads((out / "summary.json").read_text())
    assert summary["wall_time_s"] >= summary["sim_time_s"] - 1e-3
    assert summary["real_time_factor"] <= 1.0 + 1e-2


def test_plugin_run_option_edits_the_resolved_config(tmp_path, monkeypatch):
    """A plugin's run option (the mechanism behind --viz) changes the configuration
    before the build: here it lengthens the pendulum, which changes its period."""
    import json as _json

    import click
    from click.testing import CliRunner

    from snakesim.framework import cli as cli_mod
    from snakesim.framework.hookspecs import hookimpl
    from snakesim.framework.registry import build_registry

    class LengthPlugin:
        @hookimpl
        def snakesim_run_options(self):
            def apply(resolved, value):
                spec = resolved.components["pend"]
                resolved.components["pend"] = spec.model_copy(update={"params": {**spec.params, "length": value}})
            return [(click.Option(["--pend-length"], type=float, default=None), apply)]

    reg = build_registry()
    reg.pm.register(LengthPlugin())
    monkeypatch.setattr(cli_mod.run, "params", list(cli_mod.run.params))
    monkeypatch.setattr(cli_mod, "_RUN_OPTIONS", {})
    monkeypatch.setattr(cli_mod.cli, "_plugins_installed", False, raising=False)
    cli_mod.install_plugin_cli(reg)
    out = tmp_path / "o"
    res = CliRunner().invoke(cli_mod.cli, ["run", "pendulum", "--pend-length", "4.0", "--duration", "0.1",
                                           "--quiet", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "length: 4.0" in (out / "config.yaml").read_text()
    assert _json.loads((out / "summary.json").read_text())["completed"]
