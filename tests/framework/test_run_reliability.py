"""Issue 17, part 2: at run time no believable garbage, and an interrupted run keeps its data.

One test (or a few) per class: non-finite outputs (recorded and sink-read), losing data (--out
checked before the run, refused when not empty, SIGINT/SIGTERM, stale files, no --out), huge sizes
and durations, linear-algebra failures, and a step too large for the physics.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from snakesim.framework import Component, ContinuousState, Input, Output, Params
from snakesim.framework.cli import cli
from snakesim.framework.errors import ConfigError, SnakesimError
from snakesim.framework.outcomes import exit_code_of

SNAKESIM = Path(sys.executable).with_name("snakesim")


class BadAfterParams(Params):
    t_bad: float = 0.05
    value: float = 1e308       # times 10: the output overflows to inf
    shape: int = 3


class BadAfter(Component[BadAfterParams]):
    """Outputs t in every element, and from t_bad on one element overflows to inf (the state stays finite)."""

    type_name = "test_bad_after"
    Params = BadAfterParams
    y = Output(shape=lambda c: (c.p.shape,), unit="1", feedthrough=())

    def output(self, t, x, u, y):
        y.y[...] = t
        if t >= self.p.t_bad - 1e-12:
            with np.errstate(over="ignore"):
                y.y[1] = self.p.value * 10.0


class UndefinedUntil(Component[BadAfterParams]):
    """An output that declares NaN a value ("not defined yet", like a settle time before the latch):
    NaN before t_bad, t after; with shape = 0, +inf from t_bad on instead."""

    type_name = "test_undefined_until"
    Params = BadAfterParams
    y = Output(unit="s", feedthrough=(), may_be_nan=True)

    def output(self, t, x, u, y):
        if t < self.p.t_bad - 1e-12:
            y.y[...] = np.nan
        else:
            y.y[...] = np.inf if self.p.shape == 0 else t


class SingularAfter(Component[BadAfterParams]):
    """A first-order state whose derivative (or, with shape=0, output) solves a singular system from t_bad."""

    type_name = "test_singular_after"
    Params = BadAfterParams
    y = Output(unit="1", feedthrough=())

    def continuous_state(self):
        return ContinuousState(np.array([1.0]))

    def _solve(self, t):
        m = np.zeros((2, 2)) if t >= self.p.t_bad - 1e-12 else np.eye(2)
        return np.linalg.solve(m, np.ones(2))

    def output(self, t, x, u, y):
        y.y[...] = x[0] if self.p.shape else self._solve(t)[0]

    def derivative(self, t, x, u, dx):
        dx[0] = -x[0] if not self.p.shape else -self._solve(t)[0]


class Sink(Component[Params]):
    type_name = "test_sink"
    is_sink = True
    u = Input(shape=None, unit=None)

    def update(self, t, xd, u):
        pass


@pytest.fixture
def reg(registry):
    for cls in (BadAfter, SingularAfter, UndefinedUntil, Sink):
        if cls.type_name not in registry.components:
            registry.add_component(cls)
    return registry


@pytest.fixture
def scene2(write_yaml, reg):
    from snakesim.framework.session import load_session

    def make(text, **kw):
        return load_session(write_yaml(text), registry=reg, **kw)
    return make


OSC = """
sim: {duration: 0.2, dt: 0.01, integrator: rk4}
components:
  osc: {type: test_oscillator}
  bad: {type: test_bad_after, params: {t_bad: 0.05}}
"""


# -- 1. non-finite outputs -----------------------------------------------------------------------

def test_a_non_finite_recorded_output_stops_naming_component_port_and_value(scene2, tmp_path):
    s = scene2(OSC + "record: [osc.x, bad.y]\n")
    r = s.run(out_dir=tmp_path / "out")
    sm = r.summary
    assert not sm["completed"]
    assert "non-finite recorded output of component 'bad'" in sm["stop_reason"]
    assert "bad.y[1] = inf" in sm["stop_reason"] and "at t = 0.05 s" in sm["stop_reason"]
    # nothing non-finite was kept, every good row was, and the state at the stop is saved
    assert np.isfinite(r.log.rows).all() and r.log.rows[-1, 0] == pytest.approx(0.04)
    assert r.last_good_state["t"] == pytest.approx(0.05)
    assert np.isfinite(r.last_good_state["X"]).all()
    text = (tmp_path / "out" / "signals.csv").read_text()
    assert "inf" not in text and "nan" not in text
    assert (tmp_path / "out" / "last_good_state.npz").is_file()
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["stop_reason"] == sm["stop_reason"]


def test_nan_passes_only_where_a_port_declares_it_a_value_and_inf_never(scene2):
    """A port with may_be_nan records its NaN ("not defined yet") and is read by a sink; ±inf in the
    same port still stops the run, naming it."""
    undefined = OSC.replace("bad: {type: test_bad_after, params: {t_bad: 0.05}}",
                            "und: {type: test_undefined_until, params: {t_bad: 0.05}}")
    s = scene2(undefined + "  sink: {type: test_sink}\nconnections: [und.y -> sink.u]\nrecord: [und.y]\n")
    r = s.run()
    assert r.summary["completed"], r.summary["stop_reason"]
    y = r.log.rows[:, 1]
    assert np.isnan(y[:5]).all() and np.isfinite(y[5:]).all()
    s = scene2(undefined.replace("t_bad: 0.05}", "t_bad: 0.05, shape: 0}") + "record: [und.y]\n")
    r = s.run()
    assert not r.summary["completed"]
    assert "non-finite recorded output of component 'und'" in r.summary["stop_reason"]
    assert "und.y = inf" in r.summary["stop_reason"]


def test_a_non_finite_output_read_by_a_sink_stops_before_the_sink_reads_it(scene2):
    s = scene2(OSC + "  sink: {type: test_sink}\nconnections: [bad.y -> sink.u]\nrecord: [osc.x]\n")
    r = s.run()
    reason = r.summary["stop_reason"]
    assert reason.startswith("non-finite output 'bad.y' of component 'bad', read by sink 'sink' (u) at t = 0.05 s")
    assert "first [1] = inf" in reason
    assert r.last_good_state is not None and r.last_good_state["t"] == pytest.approx(0.05)


def test_a_sink_with_a_rate_is_checked_at_its_own_ticks_only(scene2):
    # at 20 Hz the sink reads at t = 0, 0.05, ...; the bad value appears at 0.06 and is seen at 0.1
    s = scene2(OSC.replace("t_bad: 0.05", "t_bad: 0.06")
               + "  sink: {type: test_sink, rate: 20}\nconnections: [bad.y -> sink.u]\nrecord: [osc.x]\n")
    assert "at t = 0.1 s" in s.run().summary["stop_reason"]


def test_finite_outputs_still_run_to_the_end(scene2):
    s = scene2(OSC.replace("t_bad: 0.05", "t_bad: 5.0") + "  sink: {type: test_sink}\n"
               "connections: [bad.y -> sink.u]\nrecord: [osc.x, bad.y]\n")
    r = s.run()
    assert r.summary["completed"] and r.last_good_state is None and r.log.n == 21


# -- 4. linear-algebra failures --------------------------------------------------------------------

@pytest.mark.parametrize("integrator", ["rk4", "rosenbrock2", "dopri5"])
def test_a_singular_matrix_inside_the_integrator_is_a_named_stop(scene2, tmp_path, integrator):
    # the stage at t + dt of the step from 0.09 s meets the singular matrix inside the integrator
    s = scene2(f"""
        sim: {{duration: 0.2, dt: 0.01, integrator: {integrator}}}
        components:
          lin: {{type: test_singular_after, params: {{t_bad: 0.1, shape: 1}}}}
        record: [lin.y]
        """)
    r = s.run(out_dir=tmp_path / "o")
    reason = r.summary["stop_reason"]
    assert reason.startswith(f"integrator {integrator} failed after t = ")
    assert "in component 'lin'" in reason and "LinAlgError: Singular matrix" in reason
    assert r.last_good_state is not None and np.isfinite(r.last_good_state["X"]).all()
    assert (tmp_path / "o" / "last_good_state.npz").is_file()


def test_a_singular_matrix_in_an_output_is_a_named_stop(scene2):
    # semi-implicit Euler evaluates outputs only in the step's major pass: the failure is the component's
    s = scene2("""
        sim: {duration: 0.2, dt: 0.01, integrator: semi_implicit_euler}
        components:
          lin: {type: test_singular_after, params: {t_bad: 0.1, shape: 0}}
        record: [lin.y]
        """)
    r = s.run()
    assert r.summary["stop_reason"].startswith("component 'lin' failed at t = 0.1 s: LinAlgError: Singular matrix")
    assert r.last_good_state["t"] == pytest.approx(0.1)


# -- 3. huge sizes and durations -------------------------------------------------------------------

def test_a_step_count_beyond_the_limit_is_refused_naming_it(scene2):
    s = scene2(OSC + "record: [osc.x]\n", sim_overrides={"dt": 1e-300, "duration": 1.0})
    with pytest.raises(ConfigError) as e:
        s.run()
    msg = str(e.value)
    assert "sim.dt" in msg and "1e+300 steps" in msg and "at most 1e+12 steps" in msg and "dt = 1e-300" in msg


def test_a_recording_reaching_the_memory_limit_stops_the_run_keeping_its_rows(scene2, monkeypatch, tmp_path):
    """Nothing is preallocated for the whole run (a 1e11-row recording starts); when one more chunk would pass
    the limit the run stops there, naming the limit and a record rate that fits, and keeps what it recorded."""
    from snakesim.framework.recorder import CHUNK_ROWS

    monkeypatch.setenv("SNAKESIM_MEMORY_LIMIT", "5e5")       # 3 columns: 2 chunks fit (393 kB), 3 do not
    s = scene2(OSC + "record: [osc.x, osc.v]\n", sim_overrides={"duration": 1e9, "dt": 0.01})
    out = tmp_path / "out"
    r = s.run(out_dir=out)
    sm, msg = r.summary, r.summary["stop_reason"]
    n = 2 * CHUNK_ROWS
    t_stop = (n - 1) * 0.01
    assert not sm["completed"] and r.last_good_state is None and r.log.n == n
    assert msg.startswith(f"recording reached the memory limit at t = {t_stop:.6g} s: {n} rows of 2 signal columns")
    assert "the limit is 500 kB" in msg and "SNAKESIM_MEMORY_LIMIT" in msg and "set sim.record_rate to at most" in msg
    assert f"the rows so far are in {out / 'signals.csv'}" in msg
    assert sm["t_end_s"] == pytest.approx(t_stop) and r.log.rows[-1, 0] == pytest.approx(t_stop)
    data = np.loadtxt(out / "signals.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(data, r.log.rows)
    # the suggested rate fits the whole duration
    rate = float(msg.split("at most ")[1].split(" Hz")[0])
    s2 = scene2(OSC + "record: [osc.x, osc.v]\n", sim_overrides={"duration": 1e9, "dt": 0.01, "record_rate": rate})
    assert 8 * 3 * (int(1e11) // s2.plan.record_every + 1) <= 5e5
    # without --out the message says how to keep the rows on disk
    r = scene2(OSC + "record: [osc.x, osc.v]\n", sim_overrides={"duration": 1e9, "dt": 0.01}).run()
    assert "(no --out: give --out DIR to keep them on disk)" in r.summary["stop_reason"]


# -- 2. losing data --------------------------------------------------------------------------------

def _cli(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


def test_an_unwritable_out_folder_is_an_error_before_the_run(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    r = _cli("run", "pendulum", "--duration", "0.01", "--out", blocker / "run")
    assert r.exit_code == 1 and "Traceback" not in r.output
    assert f"--out {blocker / 'run'}: cannot write there" in r.stderr and "running" not in r.stderr
    r = _cli("run", "pendulum", "--duration", "0.01", "--out", blocker)
    assert r.exit_code == 2 and "is a file" in r.stderr and "Traceback" not in r.output


def test_a_non_empty_out_folder_is_refused_unless_overwrite(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    r = _cli("run", "pendulum", "--duration", "0.01", "--out", out)
    assert r.exit_code == 1 and "the folder is not empty (notes.txt)" in r.stderr and "--overwrite" in r.stderr
    assert not (out / "signals.csv").exists()
    r = _cli("run", "pendulum", "--duration", "0.01", "--out", out, "--overwrite", "--quiet")
    assert r.exit_code == 0 and (out / "signals.csv").is_file() and (out / "notes.txt").read_text() == "mine"


@pytest.mark.filterwarnings("ignore:overflow:RuntimeWarning", "ignore:invalid value:RuntimeWarning")
def test_a_stale_last_good_state_never_sits_beside_a_good_summary(tmp_path):
    out = tmp_path / "run"
    blow = ["run", "mass-spring-chain", "--set", "n=2", "--set", "k=1e6", "--dt", "0.01", "--duration", "1",
            "--integrator", "rk4", "--quiet", "--out", out]
    assert _cli(*blow).exit_code == exit_code_of("non_finite") and (out / "last_good_state.npz").is_file()
    r = _cli("run", "mass-spring-chain", "--set", "n=2", "--duration", "0.1", "--quiet", "--out", out, "--overwrite")
    assert r.exit_code == 0
    assert not (out / "last_good_state.npz").exists()
    assert json.loads((out / "summary.json").read_text())["completed"]


@pytest.mark.filterwarnings("ignore:overflow:RuntimeWarning", "ignore:invalid value:RuntimeWarning")
def test_a_blow_up_without_out_says_nothing_was_saved_and_how_to_keep_it():
    r = _cli("run", "mass-spring-chain", "--set", "n=2", "--set", "k=1e6", "--dt", "0.01", "--duration", "1",
             "--integrator", "rk4", "--quiet")
    assert r.exit_code == exit_code_of("non_finite")
    assert "nothing was saved (no --out); run again with --out DIR to keep the signals so far and the last good " \
           "state" in r.stderr


def test_unwritable_save_config_and_viz_save_paths_are_errors_before_the_run(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    r = _cli("run", "pendulum", "--duration", "0.01", "--save-config", blocker / "c.yaml")
    assert r.exit_code == 1 and f"--save-config {blocker / 'c.yaml'}: cannot write there" in r.stderr
    assert "running" not in r.stderr
    r = _cli("run", "pendulum", "--duration", "0.01", "--save-config", tmp_path)
    assert r.exit_code != 0 and "Traceback" not in r.output
    r = _cli("run", "pendulum", "--duration", "0.01", "--viz", f"save={blocker / 'x.rrd'}")
    assert r.exit_code == 2 and "cannot write there" in r.stderr and "running" not in r.stderr


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupted_run_keeps_its_signals_summary_and_config(tmp_path, sig):
    out = tmp_path / "run"
    p = subprocess.Popen([str(SNAKESIM), "run", "pendulum", "--duration", "10000", "--dt", "0.001",
                          "--set", "sim.record_rate=100", "--out", str(out)],
                         stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    try:
        line = p.stderr.readline()
        if line.startswith("compiling kernels"):      # a cold numba cache (a first run) says so first
            line = p.stderr.readline()
        assert line.startswith("running"), line
        time.sleep(1.0)          # well into the step loop
        p.send_signal(sig)
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 128 + sig, err
    assert "Traceback" not in err
    sm = json.loads((out / "summary.json").read_text())
    assert sm["completed"] is False and sm["interrupted"]["signal"] == sig.name
    assert sm["outcome"] == "failure" and sm["failure_kind"] == "interrupted"
    assert sm["stop_reason"].startswith(f"signal: interrupted by {sig.name} at t = ")
    t_end = sm["interrupted"]["at_sim_time_s"]
    assert 0 < t_end < 10000 and t_end == sm["t_end_s"] and sm["interrupted"]["wall_clock"]
    rows = (out / "signals.csv").read_text().splitlines()
    assert rows[0].startswith("t,") and len(rows) > 2
    assert float(rows[-1].split(",")[0]) == pytest.approx(t_end, abs=0.01)
    assert (out / "config.yaml").read_text().startswith("# snakesim resolved configuration")


def test_an_interrupt_before_the_run_starts_stops_it_at_its_first_step(scene2, tmp_path):
    s = scene2(OSC + "record: [osc.x]\n")
    s.interrupt("SIGINT")
    r = s.run(out_dir=tmp_path / "o")
    assert r.summary["steps"] == 0 and r.summary["interrupted"]["at_sim_time_s"] == 0.0
    assert r.log.n == 1 and (tmp_path / "o" / "summary.json").is_file()


# -- 5. a step too large for the physics -----------------------------------------------------------

class Stiff(Component[BadAfterParams]):
    """The oscillator, telling the step check its ω (value)."""

    type_name = "test_stiff"
    Params = BadAfterParams
    x = Output(unit="m", feedthrough=())

    def continuous_state(self):
        return ContinuousState(np.array([1.0, 0.0]), second_order=1)

    def output(self, t, x, u, y):
        y.x[...] = x[0]

    def derivative(self, t, x, u, dx):
        dx[0], dx[1] = x[1], -self.p.value ** 2 * x[0]

    def stiffness_hint(self, u, readers):
        return [(self.p.value, "a spring"), (1.0, "a soft one")]


@pytest.mark.parametrize("integrator, dt, warned", [("rk4", 0.01, False), ("rk4", 0.03, True),
                                                    ("semi_implicit_euler", 0.021, True),
                                                    ("semi_implicit_euler", 0.019, False),
                                                    ("rosenbrock2", 0.1, False)])
def test_a_step_past_the_stability_bound_is_warned_with_the_largest_stable_step(reg, write_yaml, caplog,
                                                                                integrator, dt, warned):
    from snakesim.framework.session import load_session

    if "test_stiff" not in reg.components:
        reg.add_component(Stiff)
    s = load_session(write_yaml(f"""
        sim: {{duration: {4 * dt}, dt: {dt}, integrator: {integrator}}}
        components:
          k: {{type: test_stiff, params: {{value: 100.0}}}}
        record: [k.x]
        """), registry=reg)
    with caplog.at_level("WARNING", logger="snakesim.run"):
        sc = s.run().summary["step_check"]
    assert sc["stiffest_mode_rad_s"] == 100.0 and sc["mode"] == "k: a spring"
    if integrator == "rosenbrock2":
        assert "dt_exceeds_stable_step" not in sc and not caplog.records
        return
    bound = 2.0 * np.sqrt(2.0) if integrator == "rk4" else 2.0
    assert sc["largest_stable_dt_s"] == pytest.approx(bound / 100.0)
    assert sc["dt_exceeds_stable_step"] is warned
    assert bool(caplog.records) is warned
    if warned:
        msg = caplog.records[0].getMessage()
        assert f"dt = {dt:g} s is past {integrator}'s stability bound" in msg and "k: a spring" in msg
        assert f"use dt <= {bound / 100.0:.3g} s" in msg


def test_the_robot_scene_estimates_contact_and_pid_modes():
    from snakesim.framework.session import load_session

    s = load_session("surface-screw-traverse", sim_overrides={"duration": 0.04, "dt": 0.02, "integrator": "rk4"})
    sc = s.run().summary["step_check"]
    assert sc["dt_exceeds_stable_step"] and sc["mode"].startswith("contact: contact")
    assert "on link 'screw_" in sc["mode"] and sc["largest_stable_dt_s"] < 0.005
    pid = s.plan.components["pid"]
    readers = lambda port: [s.plan.components["robot"]]     # noqa: E731
    modes = pid.stiffness_hint(s.plan.io["pid"][1], readers)
    inertia = s.plan.components["robot"].joint_inertia()
    assert np.all(inertia > 0) and modes
    w, what = max(modes)
    assert "over inertia" in what or "derivative filter" in what
