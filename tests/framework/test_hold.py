"""Component.hold(): a generic gate the step loop calls once per base step (pause, steps, lockstep)."""

from __future__ import annotations

import dataclasses
import logging
import time

import pytest

from snakesim.framework import Component, Output, Params
from snakesim.framework import simulator as sim_mod
from snakesim.framework.registry import build_registry
from snakesim.framework.session import load_session


@dataclasses.dataclass
class GateRun:
    calls: list = dataclasses.field(default_factory=list)
    budget: int = 3                 # steps allowed before the gate stops the run


class Gate(Component[Params]):
    """No ports at all: kept only because it holds the loop. Lets `budget` steps through, then stops."""

    type_name = "test_gate"

    def make_cache(self, x, u, y):
        return GateRun()

    def hold(self, t, u):
        run = u.cache
        run.calls.append(t)
        if len(run.calls) > run.budget:
            self.stop("gate closed")


class Clock(Component[Params]):
    type_name = "test_clock"
    y = Output(unit="s", feedthrough=())

    def output(self, t, x, u, y):
        y.y[...] = t


class Sleeper(Component[Params]):
    """Holds the loop 0.2 s once (e.g. an operator pause)."""

    type_name = "test_sleeper"

    def make_cache(self, x, u, y):
        return GateRun()

    def hold(self, t, u):
        if not u.cache.calls:
            time.sleep(0.2)
        u.cache.calls.append(t)


@pytest.fixture(scope="module")
def reg():
    r = build_registry(load_entry_points=False)
    for c in (Gate, Clock, Sleeper):
        r.add_component(c)
    return r


def _session(tmp_path, reg, comps: str, duration=0.1, dt=0.01):
    p = tmp_path / "scene.yaml"
    p.write_text(f"sim: {{duration: {duration}, dt: {dt}}}\ncomponents:\n{comps}")
    return load_session(p, registry=reg)


def test_hold_is_called_once_per_base_step_not_at_the_last_tick(tmp_path, reg):
    s = _session(tmp_path, reg, "  gate: {type: test_gate}\n  clock: {type: test_clock}\n")
    assert "gate" not in s.plan.pruned and len(s.plan.holds) == 1
    s.plan.caches["gate"].budget = 10 ** 6
    r = s.run()
    calls = s.plan.caches["gate"].calls
    assert r.summary["completed"] and r.summary["steps"] == 10
    assert [round(t, 9) for t in calls] == [round(0.01 * k, 9) for k in range(10)]
    assert "held_wall_time_s" in r.summary


def test_a_gate_can_end_the_run(tmp_path, reg):
    s = _session(tmp_path, reg, "  gate: {type: test_gate}\n")
    r = s.run()
    assert not r.summary["completed"]
    assert "gate closed" in r.summary["stop_reason"] and r.summary["steps"] == 4


def test_no_hold_no_gates(tmp_path, reg):
    s = _session(tmp_path, reg, "  clock: {type: test_clock}\n  c2: {type: test_clock}\n")
    assert s.plan.holds == ()


def test_realtime_does_not_count_held_time_as_lag(tmp_path, reg, caplog):
    s = _session(tmp_path, reg, "  sleeper: {type: test_sleeper}\n", duration=0.3, dt=0.01)
    with caplog.at_level(logging.WARNING, logger="snakesim.run"):
        r = s.run(realtime=True)
    assert r.summary["held_wall_time_s"] >= 0.2
    assert r.summary["realtime_max_lag_s"] < sim_mod.LAG_WARN_S
    assert not [m for m in caplog.messages if "behind the wall clock" in m]
    assert r.summary["wall_time_s"] >= 0.3 + 0.2 - 0.02     # paced after the hold, not caught up


class Slow(Component[Params]):
    type_name = "test_slow"
    is_sink = True

    def update(self, t, xd, u):
        time.sleep(0.03)          # 3x slower than real time at dt = 0.01


def test_realtime_lag_is_reported(tmp_path, reg, caplog, monkeypatch):
    reg.add_component(Slow)
    monkeypatch.setattr(sim_mod, "LAG_WARN_S", 0.05)
    s = _session(tmp_path, reg, "  slow: {type: test_slow}\n", duration=0.2, dt=0.01)
    with caplog.at_level(logging.WARNING, logger="snakesim.run"):
        r = s.run(realtime=True)
    warned = [m for m in caplog.messages if "behind the wall clock" in m]
    assert len(warned) == 1                 # rate-limited: one per LAG_WARN_EVERY_S
    assert "real-time factor" in warned[0]
    assert r.summary["realtime_max_lag_s"] > 0.2
