"""Build-time resources (``Uses``/``Provides``), the framework-owned per-run cache, the frozen plan
and port roles.

A resource is built once by its provider and handed to every user before its
``setup()``, so port shapes follow it; the binding is by kind when one
component provides it, by name (``uses:``) otherwise, and every mistake is a
ConfigError naming the component and the valid choices.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydantic import Field

from snakesim.framework import (Component, ConfigError, ContinuousState, Harness, Input, Output, Params, Provides,
                                Uses)
from snakesim.framework.registry import build_registry
from snakesim.framework.session import load_session


class Gains:
    """A toy resource: a gain per channel (stands in for the robot model)."""

    def __init__(self, values):
        self.values = np.asarray(values, dtype=float)
        self.n = self.values.size


class BankParams(Params):
    values: list[float] = Field(default_factory=lambda: [1.0, 2.0, 3.0])


class Bank(Component[BankParams]):
    """Provides the Gains; has state so it is never pruned."""

    type_name = "test_gain_bank"
    Params = BankParams
    gains = Provides(Gains)
    level = Output(shape=lambda c: (c.gains.n,), unit="1", feedthrough=())

    def setup(self):
        self.gains = Gains(self.p.values)

    def continuous_state(self):
        return ContinuousState(np.zeros(1))

    def output(self, t, x, u, y):
        y.level[:] = self.gains.values

    def derivative(self, t, x, u, dx):
        dx[0] = 0.0


class Scaler(Component[Params]):
    """y = gains ⊙ u; counts make_cache calls and reads its scratch from u.cache."""

    type_name = "test_scaler"
    gains = Uses(Gains)
    u = Input(shape=lambda c: (c.gains.n,), unit="1")
    y = Output(shape=lambda c: (c.gains.n,), unit="1", feedthrough=True)
    caches_made = 0

    def make_cache(self, x, u, y):
        type(self).caches_made += 1
        return {"product": np.zeros(self.gains.n), "inputs": u.u, "outputs": y.y}

    def output(self, t, x, u, y):
        c = u.cache
        assert c["inputs"] is u.u and c["outputs"] is y.y      # bound to this plan's buffers
        np.multiply(self.gains.values, u.u, out=c["product"])
        y.y[:] = c["product"]


class Watcher(Component[Params]):
    """Optionally uses the Gains: None when no component provides them."""

    type_name = "test_watcher"
    is_sink = True
    gains = Uses(Gains, required=False)
    n = Output(unit="1", feedthrough=())

    def output(self, t, x, u, y):
        y.n[...] = -1 if self.gains is None else self.gains.n

    def update(self, t, xd, u):
        pass


class Angles(Component[Params]):
    """A position and a rate output, each with its role."""

    type_name = "test_angles"
    q = Output(unit="rad", feedthrough=(), role="joint_positions")
    v = Output(unit="rad", feedthrough=(), role="joint_velocities")   # same unit on purpose: only the role differs

    def output(self, t, x, u, y):
        y.q[...], y.v[...] = 1.0, 2.0


class Servo(Component[Params]):
    type_name = "test_servo"
    q = Input(unit="rad", role="joint_positions")
    tau = Output(unit="N*m", feedthrough=True)

    def output(self, t, x, u, y):
        y.tau[...] = -u.q


class Broken(Component[Params]):
    """Declares a resource and forgets to build it."""

    type_name = "test_broken_provider"
    gains = Provides(Gains)


@pytest.fixture(scope="module")
def reg():
    r = build_registry(load_entry_points=False)
    for cls in (Bank, Scaler, Watcher, Broken, Angles, Servo):
        r.add_component(cls)
    return r


@pytest.fixture
def scene(tmp_path, reg):
    def make(text: str):
        path = tmp_path / "scene.yaml"
        path.write_text("sim: {duration: 0.01, dt: 0.001, integrator: rk4}\n" + text)
        return load_session(path, registry=reg)
    return make


def test_users_get_the_providers_object_and_shapes_follow_it(scene):
    s = scene("components:\n  bank: {type: test_gain_bank, params: {values: [2.0, -1.0]}}\n"
              "  scale: {type: test_scaler}\n  watch: {type: test_watcher}\n"
              "connections: [bank.level -> scale.u]\nrecord: [scale.y, watch.n]\n")
    bank, scale = s.plan.components["bank"], s.plan.components["scale"]
    assert scale.gains is bank.gains                     # one object, built once
    assert s.report()["resources"] == {"scale": {"gains": "bank"}, "watch": {"gains": "bank"}}
    assert s.plan.infos["scale"]["y"].shape == (2,)
    r = s.run()
    np.testing.assert_array_equal(r["scale.y"][-1], [4.0, 1.0])
    assert r["watch.n"][-1] == 2


def test_an_optional_use_without_provider_is_none(scene):
    r = scene("components:\n  watch: {type: test_watcher}\nrecord: [watch.n]\n").run()
    assert r["watch.n"][-1] == -1


@pytest.mark.parametrize("text, match", [
    ("  scale: {type: test_scaler}\n", r"scale \(test_scaler\) uses a Gains \('gains'\), and no component"),
    ("  a: {type: test_gain_bank}\n  b: {type: test_gain_bank}\n  scale: {type: test_scaler}\n",
     r"2 components provide one \(a, b\); name one with 'uses: \{gains: NAME\}'"),
    ("  a: {type: test_gain_bank}\n  scale: {type: test_scaler, uses: {gains: nope}}\n",
     r"uses.gains = 'nope', which does not provide a Gains; components that do: a"),
    ("  a: {type: test_gain_bank}\n  scale: {type: test_scaler, uses: {robot: a}}\n",
     r"'uses' names 'robot', which test_scaler does not use; it uses: gains"),
    ("  b: {type: test_broken_provider}\n", r"setup\(\) must set self.gains to a Gains"),
])
def test_binding_mistakes_name_the_component_and_the_choices(scene, text, match):
    with pytest.raises(ConfigError, match=match):
        scene("components:\n" + text)


def test_uses_names_one_provider_among_several(scene):
    s = scene("components:\n  a: {type: test_gain_bank, params: {values: [1.0]}}\n"
              "  b: {type: test_gain_bank, params: {values: [5.0, 6.0]}}\n"
              "  scale: {type: test_scaler, uses: {gains: b}}\n"
              "connections: [b.level -> scale.u]\nrecord: [scale.y]\n")
    assert s.plan.components["scale"].gains is s.plan.components["b"].gains
    assert "uses" in s.config_dict()["components"]["scale"]             # the saved config rebinds the same way
    np.testing.assert_array_equal(s.run()["scale.y"][-1], [25.0, 36.0])


def test_a_component_alone_takes_its_resources_in_the_harness():
    h = Harness(Scaler, uses={"gains": Gains([3.0, 4.0])})
    h.inputs.u = [1.0, 0.5]
    np.testing.assert_array_equal(h.outputs()["y"], [3.0, 2.0])
    with pytest.raises(ValueError, match="needs a Gains \\('gains'\\)"):
        Harness(Scaler)


def test_each_build_makes_its_own_cache_and_nobody_rebinds_it(scene):
    before = Scaler.caches_made
    text = ("components:\n  bank: {type: test_gain_bank}\n  scale: {type: test_scaler}\n"
            "connections: [bank.level -> scale.u]\nrecord: [scale.y]\n")
    s1, s2 = scene(text), scene(text)
    assert Scaler.caches_made == before + 2
    u1 = s1.plan.components["scale"]
    assert not hasattr(u1, "cache") and not any(isinstance(v, dict) for v in vars(u1).values())
    (_, _, u, _), = [c for c in s1.plan.major[0] if c[0].__self__ is u1]
    assert u.cache is not None and s1.plan.caches["scale"] is u.cache
    assert s2.plan.caches["scale"] is not u.cache
    with pytest.raises(AttributeError, match="made by the framework"):
        u.cache = {}
    s1.run(), s2.run()
    assert Scaler.caches_made == before + 2                              # runs reuse the build's cache


def test_the_plan_is_frozen_and_a_run_leaves_it_as_built(scene):
    """Records, stops, a sink, a rated component and a sampled output group: all decided at build."""
    s = scene("components:\n  bank: {type: test_gain_bank}\n  scale: {type: test_scaler}\n"
              "  watch: {type: test_watcher, rate: 500}\n"
              "connections: [bank.level -> scale.u]\nrecord: [scale.y, watch.n]\n"
              "stop: [{signal: scale.y, index: 0, above: 1.0e9}]\n")
    plan = s.plan
    fields = {f.name: getattr(plan, f.name) for f in dataclasses.fields(plan)}
    with pytest.raises(dataclasses.FrozenInstanceError):
        plan.record_every = 7
    for name in ("nodes", "minor", "major", "updates", "derivs", "once", "slices", "stops", "record_refs"):
        assert isinstance(fields[name], tuple), name
    assert len(plan.stops) == 1 and plan.n_phases == 2
    s.run()
    s.run()
    for name, value in fields.items():
        assert getattr(plan, name) is value, name


def test_ports_with_declared_roles_connect_only_to_the_same_role(scene):
    """A role says what a port carries: rates wired into a position input fail at build, naming both."""
    ok = scene("components:\n  a: {type: test_angles}\n  s: {type: test_servo}\n"
               "connections: [a.q -> s.q]\nrecord: [s.tau]\n")
    assert ok.run()["s.tau"][-1] == -1.0
    with pytest.raises(Exception, match=r"cannot connect a.v .* -> s.q .*carries joint_velocities, the input "
                                        r"expects joint_positions"):
        scene("components:\n  a: {type: test_angles}\n  s: {type: test_servo}\n"
              "connections: [a.v -> s.q]\nrecord: [s.tau]\n")
