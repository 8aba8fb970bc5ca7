"""Unit tests: signals, ports, binding, registry and the single-component harness."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from pydantic import ValidationError

from snakesim.components.examples.pendulum import Pendulum, ViscousDamper
from snakesim.components.signals.blocks import Gain, ZeroOrderHold
from snakesim.framework import Component, Harness, Input, Output, Params
from snakesim.framework.binding import Cell, make_namespace
from snakesim.framework.errors import RegistryError
from snakesim.framework.registry import Registry
from snakesim.framework.signals import normalize_unit, resolve_shape


# -- signals -----------------------------------------------------------------------

class ShapeParams(Params):
    n: int = 4
    m: int = 3


def test_resolve_shape_from_params():
    c = SimpleNamespace(p=ShapeParams(n=4, m=3))          # shapes see the component: its params as c.p
    assert resolve_shape("n", c, "c.u") == (4,)
    assert resolve_shape(("n", 3), c, "c.u") == (4, 3)
    assert resolve_shape(("m", "n"), c, "c.u") == (3, 4)
    assert resolve_shape(lambda comp: (comp.p.n * 2,), c, "c.u") == (8,)
    assert resolve_shape(5, c, "c.u") == (5,)
    assert resolve_shape((), c, "c.u") == ()
    assert resolve_shape(None, c, "c.u") is None


def test_resolve_shape_errors_name_the_port():
    with pytest.raises(AttributeError, match=r"c\.u: shape names parameter 'k'"):
        resolve_shape(("k",), SimpleNamespace(p=ShapeParams()), "c.u")
    with pytest.raises(ValueError, match=r"c\.u: shape dimension -1 is negative"):
        resolve_shape((-1,), SimpleNamespace(p=ShapeParams()), "c.u")


@pytest.mark.parametrize("a, b", [("N·m", "N*m"), ("N * m", "N*m"), ("m/s^2", "m/s**2"), ("", "1")])
def test_unit_normalisation(a, b):
    assert normalize_unit(a) == normalize_unit(b)


def test_unit_normalisation_keeps_distinct_units_apart():
    assert normalize_unit("rad") != normalize_unit("rad/s")
    assert normalize_unit(None) is None


# -- ports ---------------------------------------------------------------------------

def test_ports_are_collected_by_attribute_name_including_inherited():
    class Base(Component[Params]):
        a = Input(unit="m")
        y = Output(unit="m", feedthrough=("a",))

    class Derived(Base):
        b = Input(unit="m", default=0.0)
        z = Output(unit="m", feedthrough=())

    assert list(Derived.inputs) == ["a", "b"]
    assert list(Derived.outputs) == ["y", "z"]
    assert Derived.inputs["a"].required and not Derived.inputs["b"].required
    assert Derived.outputs["y"].feedthrough_inputs(["a", "b"]) == ("a",)
    assert Derived.outputs["z"].feedthrough_inputs(["a", "b"]) == ()


def test_port_declaration_errors():
    with pytest.raises(TypeError, match="feedthrough names unknown inputs"):
        class BadFeed(Component[Params]):
            y = Output(feedthrough=("nope",))
    with pytest.raises(TypeError, match="calc method 'calc_y' is not defined"):
        class BadCalc(Component[Params]):
            y = Output(calc="calc_y")


def test_params_are_frozen_and_reject_unknown_keys():
    p = Pendulum("pend", {"length": 2.0})
    assert p.p.length == 2.0
    with pytest.raises(ValidationError):
        p.p.length = 3.0
    with pytest.raises(ValidationError, match="lenght"):
        Pendulum("pend", {"lenght": 2.0})


def test_rate_must_be_positive():
    with pytest.raises(ValueError, match="rate must be > 0"):
        ZeroOrderHold("zoh", {}, rate=-5.0)


# -- binding --------------------------------------------------------------------------

def test_rebinding_a_numeric_output_raises_with_the_hint():
    buf = np.zeros(3)
    y = make_namespace("g", "outputs", {"y": buf}, {})
    y.y[...] = 2.0                      # in place: allowed, lands in the shared buffer
    assert np.all(buf == 2.0)
    with pytest.raises(AttributeError, match=r"cannot rebind outputs 'y'; write into the buffer instead: y\.y\[\.\.\.\] = value"):
        y.y = np.ones(3)
    assert np.all(buf == 2.0)
    with pytest.raises(AttributeError, match="has no output 'z'"):
        y.z = 1.0


def test_inputs_are_read_only():
    upstream = np.arange(3.0)
    view = upstream.view()
    view.flags.writeable = False
    cell = Cell("hello")
    u = make_namespace("g", "inputs", {"u": view}, {"w": cell})
    with pytest.raises(AttributeError, match="inputs are read-only"):
        u.u = np.zeros(3)
    with pytest.raises(ValueError):
        u.u[0] = 5.0                    # the view itself is not writable
    with pytest.raises(AttributeError, match="inputs are read-only"):
        u.w = "bye"                     # structured inputs are read-only too
    upstream[1] = 7.0                   # zero copy: the input sees the upstream change
    assert u.u[1] == 7.0
    assert u.w == "hello"


def test_structured_values_travel_through_the_shared_cell():
    cell = Cell()
    y = make_namespace("src", "outputs", {}, {"w": cell})
    u = make_namespace("dst", "inputs", {}, {"w": cell})
    value = {"force": 1.5}
    y.w = value
    assert u.w is value
    y.w = None
    assert u.w is None


# -- registry -------------------------------------------------------------------------

def test_unknown_component_type_lists_close_matches(registry):
    with pytest.raises(RegistryError) as e:
        registry.component("pendulm")
    assert "unknown component type 'pendulm'" in str(e.value)
    assert "'pendulum'" in str(e.value)


def test_duplicate_registration_names_both_classes():
    reg = Registry()
    reg.add_component(Gain)

    class Gain2(Component[Params]):
        type_name = "gain"

    with pytest.raises(RegistryError) as e:
        reg.add_component(Gain2)
    msg = str(e.value)
    assert "'gain' registered twice" in msg
    assert "snakesim.components.signals.blocks.Gain" in msg
    assert f"{Gain2.__module__}.{Gain2.__qualname__}" in msg
    reg.add_component(Gain)             # the same class again is harmless
    assert reg.component("gain") is Gain


def test_registry_rejects_non_components_and_derives_names():
    reg = Registry()
    with pytest.raises(RegistryError, match="not a snakesim Component subclass"):
        reg.add_component(int)

    class MyFancyBlock(Component[Params]):
        pass

    reg.add_component(MyFancyBlock)
    assert reg.component("my_fancy_block") is MyFancyBlock


def test_builtin_registry_has_every_integrator(registry):
    assert {"semi_implicit_euler", "rk4", "dopri5", "rosenbrock2"} <= set(registry.integrators)
    with pytest.raises(RegistryError, match="'rk4'"):
        registry.integrator("rk5")


# -- harness --------------------------------------------------------------------------

def test_harness_pendulum_outputs_and_derivative_follow_the_equation():
    L, m, g, th0, w0 = 2.0, 3.0, 9.81, 0.7, -0.4
    h = Harness(Pendulum, {"length": L, "mass": m, "gravity": g, "theta0": th0, "omega0": w0})
    tau = 1.25
    h.inputs.tau = tau
    out = h.outputs()
    assert out["theta"] == th0 and out["omega"] == w0
    dx = h.derivative()
    # m L² θ̈ = −m g L sin θ + τ
    assert dx[0] == pytest.approx(w0, rel=1e-15)
    assert dx[1] == pytest.approx(-g / L * np.sin(th0) + tau / (m * L * L), rel=1e-14)
    h.inputs.tau = 0.0
    assert h.derivative()[1] == pytest.approx(-g / L * np.sin(th0), rel=1e-14)


def test_harness_damper_feedthrough():
    h = Harness(ViscousDamper, {"c": 0.3})
    h.inputs.omega = 2.0
    assert h.outputs()["tau"] == pytest.approx(-0.6, rel=1e-15)


def test_harness_zero_order_hold_update_samples_and_holds():
    h = Harness(ZeroOrderHold, {"n": 3}, rate=100.0)
    np.testing.assert_array_equal(h.outputs()["y"], np.zeros(3))
    h.inputs.u = [1.0, 2.0, 3.0]
    np.testing.assert_array_equal(h.outputs()["y"], np.zeros(3))     # not sampled yet
    np.testing.assert_array_equal(h.update(), [1.0, 2.0, 3.0])
    h.inputs.u = [9.0, 9.0, 9.0]
    np.testing.assert_array_equal(h.outputs()["y"], [1.0, 2.0, 3.0])  # held until the next update
    np.testing.assert_array_equal(h.update(), [9.0, 9.0, 9.0])


def test_harness_unknown_input_is_named():
    h = Harness(Pendulum)
    with pytest.raises(KeyError, match="has no input 'torque'"):
        h.inputs.torque = 1.0


def test_harness_structured_ports(registry):
    h = Harness(registry.component("test_wrench_to_force"))
    w = registry.component("test_wrench_source").outputs["w"].signal.cls(force=4.0, torque=0.0)
    h.inputs.w = w
    assert h.outputs()["force"] == 4.0


def test_harness_inputs_start_at_their_declared_defaults():
    class Offset(Component[Params]):
        a = Input(shape=(3,), unit="m", default=np.array([1.0, 2.0, 3.0]))
        b = Input(unit="m", default=0.5)
        y = Output(shape=(3,), unit="m", feedthrough=True)

        def output(self, t, x, u, y):
            np.add(u.a, u.b, out=y.y)

    h = Harness(Offset)
    np.testing.assert_array_equal(h.outputs()["y"], [1.5, 2.5, 3.5])
    h.inputs.b = -1.0
    np.testing.assert_array_equal(h.outputs()["y"], [0.0, 1.0, 2.0])


def test_augmented_assignment_on_an_output_works_in_place():
    buf = np.zeros(2)
    y = make_namespace("s", "outputs", {"y": buf}, {})
    y.y += 1.5                      # in place, then Python rebinds the same array
    np.testing.assert_array_equal(buf, [1.5, 1.5])


def test_harness_sine_with_offset():
    from snakesim.components.signals.sources import Sine

    h = Harness(Sine, {"amplitude": 2.0, "frequency": 0.5, "offset": 1.0, "phase": 0.3, "n": 2})
    t = 0.7
    np.testing.assert_allclose(h.outputs(t)["y"], 1.0 + 2.0 * np.sin(np.pi * t + 0.3), rtol=1e-15)
