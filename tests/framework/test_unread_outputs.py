"""Outputs nobody reads: components are told which of their ports are read
(``bind_outputs``), and a ``calc`` port group nobody reads is not evaluated.

A port is read when it is connected to a kept component, recorded or tested by
a stop condition. ``output()`` always runs (it may stop the run), so the
component itself decides what to skip there.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from snakesim.framework import Component, Input, Output, Params
from snakesim.framework.registry import build_registry
from snakesim.framework.session import load_session
from snakesim.framework.wiring import PortRef


class Probe(Component[Params]):
    """y = t from output(); costly = 2t from its own calc method; counts both."""

    type_name = "test_probe"
    y = Output(unit="s", feedthrough=())
    costly = Output(unit="s", feedthrough=(), calc="calc_costly")

    def setup(self):
        self.calls = {"output": 0, "costly": 0}
        self.bound = None

    def bind_outputs(self, used):
        super().bind_outputs(used)
        self.bound = used

    def output(self, t, x, u, y):
        self.calls["output"] += 1
        y.y[...] = t

    def calc_costly(self, t, x, u, y):
        self.calls["costly"] += 1
        y.costly[...] = 2.0 * t


class Reader(Component[Params]):
    type_name = "test_reader"
    is_sink = True
    u = Input(unit="s")

    def update(self, t, xd, u):
        pass


@pytest.fixture(scope="module")
def reg():
    r = build_registry(load_entry_points=False)
    r.add_component(Probe)
    r.add_component(Reader)
    return r


def _session(write, reg, extra: str):
    path = write("sim: {duration: 0.05, dt: 0.01}\ncomponents:\n  probe: {type: test_probe}\n"
                 "  sink: {type: test_reader}\n" + extra)
    return load_session(path, registry=reg)


@pytest.fixture
def write(tmp_path):
    def w(text):
        p = tmp_path / "scene.yaml"
        p.write_text(text)
        return p
    return w


def test_unread_calc_group_is_skipped_and_output_still_runs(write, reg):
    s = _session(write, reg, "connections: [probe.y -> sink.u]\n")
    probe = s.plan.components["probe"]
    assert probe.bound == frozenset({"y"})
    assert probe.used_outputs == frozenset({"y"})
    assert s.report()["unread_outputs"] == ["probe.costly"]
    s.run()
    assert probe.calls == {"output": 6, "costly": 0}       # 6 major passes (t = 0 .. 0.05)


@pytest.mark.parametrize("how", ["connections: [probe.costly -> sink.u]\n",
                                 "connections: [probe.y -> sink.u]\nrecord: [probe.costly]\n",
                                 "connections: [probe.y -> sink.u]\n"
                                 "stop: [{signal: probe.costly, above: 1.0e9}]\n"])
def test_read_calc_group_is_evaluated(write, reg, how):
    s = _session(write, reg, how)
    probe = s.plan.components["probe"]
    assert "costly" in probe.bound
    r = s.run()
    assert probe.calls["costly"] == 6
    if "record" in how:
        np.testing.assert_allclose(r["probe.costly"], 2.0 * r["t"], rtol=0, atol=1e-15)


def test_recording_is_decided_at_build_and_the_plan_is_frozen(write, reg):
    """A record is part of the build: the same scene built with the port recorded evaluates it,
    and nothing can change a built plan afterwards (no later 'require')."""
    s = _session(write, reg, "connections: [probe.y -> sink.u]\n")
    assert s.plan.components["probe"].calls["costly"] == 0
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.plan.major = ()
    r = _session(write, reg, "connections: [probe.y -> sink.u]\nrecord: [probe.costly]\n")
    probe = r.plan.components["probe"]
    r.run()
    assert probe.bound == frozenset({"y", "costly"})
    assert probe.calls["costly"] == 6


def test_a_component_outside_a_build_reads_every_output():
    assert Probe("p").used_outputs == frozenset({"y", "costly"})
