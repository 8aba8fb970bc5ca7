"""Component.edit_state(): requests to reset or write the state between steps (framework/state_edit.py).

A run that moves (an oscillator, a rotor on its manifold, a discrete counter), a requester that resets or
writes at a chosen tick, and a probe that snapshots the plan's X and XD at every output pass: after a
reset the state at the next tick equals X0 and XD0 bit for bit, time keeps going forward, and the
integrator keeps no memory of the steps before."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from framework_components import Oscillator, Rotor
from snakesim.framework import Builder, Component, Output, Params
from snakesim.framework.state_edit import StateEdit
from state_probe import StateProbe


class CountParams(Params):
    step: float = 1.0


class Counter(Component[CountParams]):
    """Discrete: xd += step at each tick; its output is the count."""

    type_name = "test_counter"
    Params = CountParams
    n = Output(unit="1", feedthrough=())

    def discrete_state(self):
        return np.array([0.0, 5.0])

    def output(self, t, x, u, y):
        y.n[...] = x[0]

    def update(self, t, xd, u):
        xd[0] += self.p.step
        xd[1] *= 1.5


@dataclasses.dataclass
class EditRun:
    at: list = dataclasses.field(default_factory=list)      # ticks (s) at which to request
    calls: list = dataclasses.field(default_factory=list)   # every tick the hook saw
    request: object = None                                   # request(edit) -> None
    observe: object = None                                   # observe() -> value kept per tick
    observed: list = dataclasses.field(default_factory=list)


class RequesterParams(Params):
    pass


class Requester(Component[RequesterParams]):
    """No ports: kept because it edits. At each tick in ``cache.at`` it calls ``cache.request(edit)``."""

    type_name = "test_requester"
    Params = RequesterParams

    def make_cache(self, x, u, y):
        return EditRun()

    def edit_state(self, t, u, edit):
        run = u.cache
        run.calls.append(t)
        if run.observe is not None:
            run.observed.append(run.observe())
        if any(abs(t - a) < 1e-12 for a in run.at):
            run.request(edit)


class Gone(Component[Params]):
    """edit_state is never overridden: no hook list."""

    type_name = "test_plain"
    y = Output(unit="1", feedthrough=())


def _session(integrator="rk4"):
    """An oscillator, a rotor on its manifold, a discrete counter, a requester and the probe (handed the plan)."""
    b = Builder(dt=0.01, duration=0.2, integrator=integrator, record_rate=100)
    # the rotor's params as a dict: rate= given to a component is its sample rate
    osc, rot, count = b.add(Oscillator("osc", omega=3.0), Rotor("rot", {"rate": 2.0, "angle0": 0.3}),
                              Counter("count", rate=50))
    b.add(Requester("req"), StateProbe("probe", rate=100))
    b.record(osc.out.x, rot.out.angle, count.out.n)
    s = b.build()
    s.plan.caches["probe"].plan = s.plan
    return s


def test_reset_returns_every_state_to_its_initial_value_exactly_and_time_goes_on():
    s = _session()
    req = s.plan.caches["req"]
    req.at, req.request = [0.1], lambda e: e.reset()
    X0, XD0 = s.plan.X.copy(), s.plan.XD.copy()
    r = s.run()
    seen = {round(t, 9): (X, XD) for t, X, XD in s.plan.caches["probe"].seen}
    # the run moved: just before the reset the state differs from X0 and XD0 everywhere that moves
    X, XD = seen[0.1]
    assert np.all(X != X0) and np.all(XD != XD0)
    # at the next tick the state is X0, XD0 bit for bit (and so every output computed from it)
    X, XD = seen[0.11]
    np.testing.assert_array_equal(X, X0)
    np.testing.assert_array_equal(XD, XD0)
    # time never went back: the recorder's and the probe's clocks both increase by dt each row
    t = r.log["t"]
    assert np.all(np.diff(t) > 0) and len(t) == 21
    times = [t for t, _, _ in s.plan.caches["probe"].seen]
    np.testing.assert_allclose(np.diff(times), 0.01, rtol=0, atol=1e-12)
    # after the reset the world replays its first 0.1 s, shifted by 0.11 s (autonomous dynamics)
    Xa, _ = seen[0.15]
    Xb, _ = seen[0.04]
    np.testing.assert_allclose(Xa, Xb, rtol=0, atol=1e-12)
    assert r.summary["completed"] and r.summary["state_edits"] == 1
    assert r.summary["integrator"]["restarts"] == 1
    assert r.summary["t_end_s"] == pytest.approx(0.2)


def test_adaptive_integrator_restarts_with_no_step_size_memory():
    """dopri5 at a tolerance that needs sub-steps: its first base step from t0 starts at h = dt and is
    rejected until h fits; after a reset it must do exactly the same (the adapted h is forgotten)."""
    s = _session(integrator={"name": "dopri5", "params": {"rtol": 1.0e-12, "atol": 1.0e-14}})
    req = s.plan.caches["req"]
    adapted = []

    def reset(e):
        adapted.append(s.integrator.h)
        e.reset()

    req.at, req.request = [0.1], reset
    req.observe = lambda: dict(s.integrator.stats)
    X0 = s.plan.X.copy()
    r = s.run()
    assert adapted[0] is not None and adapted[0] < 0.01          # it had learnt a step size below dt
    seen = {round(t, 9): X for t, X, _ in s.plan.caches["probe"].seen}
    np.testing.assert_array_equal(seen[0.11], X0)
    st = req.observed                                            # stats before the step of each tick
    first = {k: st[1][k] - st[0][k] for k in ("f_evals", "rejected")}
    after = {k: st[12][k] - st[11][k] for k in ("f_evals", "rejected")}
    assert first["rejected"] > 0 and after == first
    assert r.summary["integrator"]["restarts"] == 1


def test_write_sets_named_elements_and_everything_else_advances():
    s = _session()
    req = s.plan.caches["req"]
    req.at, req.request = [0.1], lambda e: e.write("osc", [0, 1], [0.25, -0.5])
    ref = _session()                       # the same run without the edit
    ref.plan.caches["req"].at = []
    s.run()
    ref.run()
    seen = {round(t, 9): (X, XD) for t, X, XD in s.plan.caches["probe"].seen}
    refs = {round(t, 9): (X, XD) for t, X, XD in ref.plan.caches["probe"].seen}
    osc = next(sl.x for sl in s.plan.slices if sl.comp.name == "osc")
    rot = next(sl.x for sl in s.plan.slices if sl.comp.name == "rot")
    X, XD = seen[0.11]
    np.testing.assert_array_equal(X[osc], [0.25, -0.5])              # written exactly
    np.testing.assert_array_equal(X[rot], refs[0.11][0][rot])        # integrated over the step as usual
    np.testing.assert_array_equal(XD, refs[0.11][1])                 # discrete state untouched
    assert not np.array_equal(seen[0.15][0][osc], refs[0.15][0][osc])


def test_write_discrete_and_reset_then_write_in_order():
    s = _session()
    req = s.plan.caches["req"]

    def both(e):
        e.reset()
        e.write_discrete("count", [1], [7.0])
        e.write("rot", [0, 1], [0.0, 1.0])

    req.at, req.request = [0.05], both
    X0, XD0 = s.plan.X.copy(), s.plan.XD.copy()
    s.run()
    X, XD = {round(t, 9): (X, XD) for t, X, XD in s.plan.caches["probe"].seen}[0.06]
    rot = next(sl.x for sl in s.plan.slices if sl.comp.name == "rot")
    expect = X0.copy()
    expect[rot] = [0.0, 1.0]
    np.testing.assert_array_equal(X, expect)
    np.testing.assert_array_equal(XD, [XD0[0], 7.0])


@pytest.mark.parametrize("call,message", [
    (lambda e: e.write("nobody", [0], [1.0]), "component 'nobody' has no continuous state"),
    (lambda e: e.write("count", [0], [1.0]), "component 'count' has no continuous state"),
    (lambda e: e.write("osc", [2], [1.0]), "index out of range (its continuous state has 2 elements)"),
    (lambda e: e.write("osc", [0, 1], [1.0]), "2 indices for 1 values"),
    (lambda e: e.write("osc", [0], [float("nan")]), "value for element 0 is nan (not finite)"),
    (lambda e: e.write("osc", [1, 1], [1.0, 2.0]), "an index is given twice"),
    (lambda e: e.write_discrete("osc", [0], [1.0]), "component 'osc' has no discrete state"),
])
def test_invalid_requests_raise_and_never_reach_the_state(call, message):
    s = _session()
    e = StateEdit(s.plan, s.plan.X.copy(), s.plan.XD.copy())
    with pytest.raises(ValueError) as err:
        call(e)
    assert message in str(err.value)
    assert not e.pending


def test_no_hook_no_editor_and_no_summary_entry():
    b = Builder(dt=0.01, duration=0.05)
    b.add(Oscillator("osc"), Gone("plain"))
    s = b.build()
    assert s.plan.edits == ()
    r = s.run()
    assert "state_edits" not in r.summary and "restarts" not in r.summary["integrator"]


def test_a_requester_is_kept_and_called_once_per_base_step_not_at_the_last_tick():
    s = _session()
    assert "req" not in s.plan.pruned and len(s.plan.edits) == 1
    s.run()
    calls = s.plan.caches["req"].calls
    assert [round(t, 9) for t in calls] == [round(0.01 * k, 9) for k in range(20)]
