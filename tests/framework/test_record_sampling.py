"""Output groups read only by the recorder are evaluated on recording ticks only."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.framework import Component, ContinuousState, Output, Params
from snakesim.framework.assembly import ComponentSpec, Resolved, SimSpec
from snakesim.framework.registry import build_registry
from snakesim.framework.session import Session


class Clock(Component[Params]):
    """x' = 1; ``square`` = x² in its own calc group (counted), ``x`` from output()."""

    type_name = "test_clock"
    x = Output(feedthrough=())
    square = Output(feedthrough=(), calc="calc_square")
    calls = 0

    def continuous_state(self):
        return ContinuousState(np.array([0.0]))

    def output(self, t, x, u, y):
        y.x[...] = x[0]

    def calc_square(self, t, x, u, y):
        type(self).calls += 1
        y.square[...] = x[0] * x[0]

    def derivative(self, t, x, u, dx):
        dx[0] = 1.0


def _session(record_rate, stop=()):
    reg = build_registry()
    reg.add_component(Clock)
    resolved = Resolved(sim=SimSpec(duration=1.0, dt=0.01, integrator="rk4", record_rate=record_rate),
                        parameters={}, components={"c": ComponentSpec(type="test_clock")}, connections=[],
                        record=[("c.x", None), ("c.square", None)], stop=list(stop))
    return Session(resolved, reg)


@pytest.mark.parametrize("record_rate, expected_calls", [(10.0, 11), (None, 101)])
def test_record_only_group_runs_on_record_ticks(record_rate, expected_calls):
    s = _session(record_rate)
    Clock.calls = 0
    r = s.run()
    assert Clock.calls == expected_calls          # 100 steps: ticks 0..100, or every 10th
    t = r["t"]
    np.testing.assert_allclose(r["c.square"], t * t, rtol=1e-12, atol=1e-15)   # fresh when recorded
    assert s.report().get("sampled_output_groups", {}).get("c[square]") == (10 if record_rate else None)


def test_a_stop_tested_group_is_not_sampled():
    from snakesim.framework.assembly import StopSpec

    s = _session(10.0, stop=[(StopSpec(signal="c.square", above=0.255, reason="x > 0.505"), None)])
    Clock.calls = 0
    r = s.run()
    # checked every step on a fresh value: the first tick with x > 0.505 is t = 0.51 (x = t)
    assert r.summary["t_end_s"] == pytest.approx(0.51)
    assert "sampled_output_groups" not in s.report()


def test_time_invariant_component_is_evaluated_once_per_run():
    from snakesim.components.signals.sources import Constant

    calls = []
    reg = build_registry()

    class CountedConstant(Constant):
        type_name = "test_counted_constant"

        def output(self, t, x, u, y):
            calls.append(t)
            super().output(t, x, u, y)

    reg.add_component(CountedConstant)
    resolved = Resolved(sim=SimSpec(duration=0.1, dt=0.01), parameters={},
                        components={"k": ComponentSpec(type="test_counted_constant", params={"value": 2.5})},
                        connections=[], record=[("k.y", None)], stop=[])
    s = Session(resolved, reg)
    r = s.run()
    assert calls == [0.0]                        # once, before the first step
    np.testing.assert_array_equal(r["k.y"], 2.5)  # and held for all 11 ticks


def test_time_invariant_with_inputs_is_a_build_error():
    from snakesim.framework import Input
    from snakesim.framework.errors import BuildError

    class Bad(Component[Params]):
        type_name = "test_bad_invariant"
        time_invariant = True
        u = Input(default=0.0)
        y = Output()

    reg = build_registry()
    reg.add_component(Bad)
    resolved = Resolved(sim=SimSpec(duration=0.1, dt=0.01), parameters={},
                        components={"b": ComponentSpec(type="test_bad_invariant")}, connections=[],
                        record=[("b.y", None)], stop=[])
    with pytest.raises(BuildError, match="time_invariant but has inputs"):
        Session(resolved, reg)


@pytest.mark.parametrize("integrator", ["semi_implicit_euler", "rk4", "dopri5", "rosenbrock2"])
def test_derivative_follows_output_on_the_same_state(integrator):
    """Contract: every derivative() call comes after output() on the same (t, x), even when
    nothing reads the component's outputs during integrator stages."""
    seen = []

    class Decay(Component[Params]):
        type_name = "test_decay"
        x = Output(feedthrough=())

        def continuous_state(self):
            return ContinuousState(np.array([1.0]))

        def output(self, t, x, u, y):
            self.last = (t, x.copy())
            y.x[...] = x[0]

        def derivative(self, t, x, u, dx):
            seen.append(self.last[0] == t and np.array_equal(self.last[1], x))
            dx[0] = -x[0]

    reg = build_registry()
    reg.add_component(Decay)
    resolved = Resolved(sim=SimSpec(duration=0.05, dt=0.01, integrator=integrator), parameters={},
                        components={"d": ComponentSpec(type="test_decay")}, connections=[],
                        record=[("d.x", None)], stop=[])
    Session(resolved, reg).run()
    assert len(seen) >= 5 and all(seen)


def test_group_read_only_by_a_discrete_component_runs_at_its_ticks():
    """A 10 Hz sampler (period 10 steps) is the only reader of c.square: the group runs on
    the sampler's ticks only, and every sample it takes is fresh (x² at that tick)."""
    from snakesim.framework import Input

    class Sampler(Component[Params]):
        type_name = "test_sampler"
        u = Input()
        y = Output(feedthrough=())

        def discrete_state(self):
            return np.zeros(1)

        def output(self, t, x, u, y):
            y.y[...] = x[0]

        def update(self, t, xd, u):
            xd[0] = u.u

    reg = build_registry()
    reg.add_component(Clock)
    reg.add_component(Sampler)
    resolved = Resolved(sim=SimSpec(duration=1.0, dt=0.01, integrator="rk4"), parameters={},
                        components={"c": ComponentSpec(type="test_clock"),
                                    "s": ComponentSpec(type="test_sampler", rate=10.0)},
                        connections=[("c.square", "s.u", None)], record=[("s.y", None), ("c.x", None)], stop=[])
    s = Session(resolved, reg)
    Clock.calls = 0
    r = s.run()
    assert Clock.calls == 11
    assert s.report()["sampled_output_groups"] == {"c[square]": 10}
    t, y = r["t"], r["s.y"]
    # held sample: at a tick k*0.1 the output shows the previous sample ((k-1)*0.1)²
    ticks = np.isclose(np.mod(t + 1e-9, 0.1), 0.0, atol=1e-6) & (t > 0.05)
    np.testing.assert_allclose(y[ticks], (t[ticks] - 0.1) ** 2, rtol=1e-9, atol=1e-12)
