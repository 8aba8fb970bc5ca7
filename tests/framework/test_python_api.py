"""The Python API (issue 25 part 1): a Builder of component objects and port objects, and a
Simulation advanced in steps that keeps its state between calls.

Checks: the pendulum from objects is the pendulum from YAML bit for bit; advance_to(1) then
advance_to(2) is one run to 2 bit for bit (and snakesim's own run loop gives the same); step(n)
counts; reset() returns to X0; a wiring mistake made in the builder is reported as the YAML path
reports it, naming both ends; an open input drives the dynamics (a torque on a pendulum without
gravity: θ = τ t² / 2 m L², which RK4 integrates exactly); resources bind as from YAML; outcomes.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from snakesim.components.examples.pendulum import Pendulum, PendulumParams, ViscousDamper
from snakesim.framework import BuildError, Builder, ConfigError, SnakesimError, load

from snakesim.framework.registry import build_registry
from snakesim.framework.session import load_session
from test_resources import Bank, Gains, Scaler

PENDULUM_YAML = """\
sim: {duration: 2.0, dt: 0.001, integrator: rk4}
components:
  pend: {type: pendulum, params: {length: 1.0, mass: 1.0, theta0: 0.2}}
  damper: {type: viscous_damper, params: {c: 0.05}}
connections:
  - pend.omega -> damper.omega
  - damper.tau -> pend.tau
record: [pend.theta, pend.omega, damper.tau]
stop:
  - {signal: pend.theta, abs_above: 3.2, reason: "pendulum went over the top"}
"""


def pendulum(**sim):
    b = Builder(**{"dt": 1e-3, "duration": 2.0, "integrator": "rk4", **sim})
    pend = b.add(Pendulum("pend", length=1.0, mass=1.0, theta0=0.2))
    damper = b.add(ViscousDamper("damper", c=0.05))
    b.connect(pend.out.omega, damper.inp.omega)
    b.connect(damper.out.tau, pend.inp.tau)
    b.record(pend.out.theta, pend.out.omega, damper.out.tau)
    b.stop(pend.out.theta, abs_above=3.2, reason="pendulum went over the top")
    return b.build(), pend


def test_the_pendulum_from_objects_is_the_pendulum_from_yaml_bit_for_bit(scene):
    from_yaml = scene(PENDULUM_YAML).run()
    sim, pend = pendulum()
    sim.advance_to(2.0)
    assert sim.log.columns == from_yaml.log.columns
    assert np.array_equal(sim.log.rows, from_yaml.log.rows)
    res = sim.finish()
    assert res.summary["outcome"] == "success" and res.summary["steps"] == 2000
    assert res.summary["stop_reason"] == from_yaml.summary["stop_reason"]


def test_advancing_in_parts_is_one_run_bit_for_bit(scene):
    one, _ = pendulum()
    one.advance_to(2.0)
    parts, pend = pendulum()
    parts.advance_to(1.0)
    assert parts.t == 1.0 and parts.steps == 1000 and parts.log.n == 1001
    assert parts.summary["outcome"] is None and not parts.ended     # still running
    parts.advance_to(2.0)
    assert np.array_equal(parts.log.rows, one.log.rows)
    assert np.array_equal(parts.state(pend), one.state("pend"))
    assert np.array_equal(parts.log.rows, scene(PENDULUM_YAML).run().log.rows)      # snakesim's run()


def test_step_counts_base_steps():
    sim, _ = pendulum()
    assert sim.steps == 0 and sim.t == 0.0 and sim.log.n == 1        # at t0, its outputs recorded
    sim.step(5)
    assert sim.steps == 5 and sim.t == pytest.approx(0.005) and sim.log.n == 6
    sim.step()
    sim.step(0)
    assert sim.steps == 6 and sim.summary["steps"] == 6
    np.testing.assert_array_equal(sim.log["t"], np.arange(7) * 1e-3)
    with pytest.raises(SnakesimError, match="whole number of base steps"):
        sim.advance_to(0.0105)
    with pytest.raises(SnakesimError, match="cannot go back"):
        sim.advance_to(0.001)


def test_reset_returns_to_the_initial_state():
    sim, pend = pendulum()
    x0 = sim.state(pend)
    np.testing.assert_array_equal(x0, [0.2, 0.0])
    sim.advance_to(0.5)
    first = sim.log.rows.copy()
    assert not np.array_equal(sim.state(pend), x0)
    sim.reset()
    assert sim.t == 0.0 and sim.log.n == 1
    np.testing.assert_array_equal(sim.state(pend), x0)
    assert sim["pend.theta"] == 0.2
    sim.advance_to(0.5)
    assert np.array_equal(sim.log.rows, first)       # the same run again


def test_reading_outputs_state_and_the_log():
    sim, pend = pendulum()
    sim.advance_to(0.25)
    theta, omega = sim.state(pend)
    assert sim.value(pend.out.theta) == theta and sim["pend.omega"] == omega
    assert sim["damper.tau"] == pytest.approx(-0.05 * omega)
    assert sim.value(pend.inp.tau) == sim["damper.tau"]        # an input reads its upstream
    assert set(sim.state()) == {"pend"}
    arrays = sim.arrays()
    assert list(arrays) == ["t", "pend.theta", "pend.omega", "damper.tau"]
    assert arrays["pend.theta"][-1] == theta
    table = sim.table()
    assert table.num_rows == 251 and table.column("pend.theta").to_numpy()[-1] == theta
    with pytest.raises(SnakesimError, match="has no output 'thetta'"):
        sim.value("pend.thetta")
    with pytest.raises(SnakesimError, match="is not open .*wired from damper.tau"):
        sim.set_input(pend.inp.tau, 1.0)


def test_an_open_input_drives_the_dynamics():
    """No gravity, no damper: θ̈ = τ / (m L²); a torque set from Python at t = 0 and changed at t = 1."""
    b = Builder(dt=0.01, duration=2.0, integrator="rk4")
    pend = b.add(Pendulum("pend", PendulumParams(length=2.0, mass=0.5, gravity=0.0, theta0=0.0)))
    b.open(pend.inp.tau)
    b.record(pend.out.theta)
    sim = b.build()
    assert sim.open_inputs == ["pend.tau"]
    inertia = 0.5 * 2.0 ** 2
    sim.set_input(pend.inp.tau, 0.4)
    sim.advance_to(1.0)
    a1 = 0.4 / inertia
    assert sim["pend.theta"] == pytest.approx(0.5 * a1, abs=1e-13)      # RK4 is exact on t²
    sim.set_input("pend.tau", -0.2)            # zero-order hold from t = 1 on
    sim.advance_to(2.0)
    a2 = -0.2 / inertia
    assert sim["pend.theta"] == pytest.approx(0.5 * a1 + a1 * 1.0 + 0.5 * a2, abs=1e-13)
    assert sim["pend.omega"] == pytest.approx(a1 + a2, abs=1e-13)
    assert sim.value(pend.inp.tau) == -0.2
    sim.reset()                                # inputs back to their initial value (the default, 0)
    assert sim.value(pend.inp.tau) == 0.0
    sim.advance_to(1.0)
    assert sim["pend.theta"] == 0.0


def test_an_unconnected_required_input_is_allowed_only_when_declared_open():
    def build(open_it):
        b = Builder(dt=0.01, duration=1.0)
        damper = b.add(ViscousDamper("damper", c=2.0))
        b.record(damper.out.tau)
        if open_it:
            b.open(damper.inp.omega)
        return b.build(), damper

    with pytest.raises(BuildError, match=r"required inputs are not connected:\n  damper.omega"):
        build(False)
    sim, damper = build(True)
    sim.set_input(damper.inp.omega, 1.5)
    assert sim["damper.tau"] == -3.0          # the tick it stands at is evaluated again with the new value
    assert sim.log["damper.tau"][-1] == -3.0   # ... and its recorded row
    sim.step(3)
    np.testing.assert_array_equal(sim.log["damper.tau"], [-3.0] * 4)


def _where_free(msg: str) -> str:
    return re.sub(r" \([^()]*(?:\.yaml|\.py):\d+\)", "", msg)


@pytest.mark.parametrize("case", ["units", "direction", "unknown_port", "twice"])
def test_a_wiring_error_from_the_builder_reads_as_from_yaml(scene, case):
    yaml_conn, build = {
        "units": ("pend.theta -> damper.omega", lambda p, d, b: b.connect(p.out.theta, d.inp.omega)),
        "direction": ("damper.omega -> pend.tau", lambda p, d, b: b.connect(d.inp.omega, p.inp.tau)),
        "unknown_port": ("pend.omega -> damper.omegga", lambda p, d, b: b.connect(p.out.omega, "damper.omegga")),
        "twice": ("pend.omega -> damper.omega, damper.omega",
                  lambda p, d, b: b.connect(p.out.omega, d.inp.omega, d.inp.omega)),
    }[case]
    with pytest.raises(BuildError) as from_yaml:
        scene("components:\n  pend: {type: pendulum}\n  damper: {type: viscous_damper}\n"
              f"connections: ['{yaml_conn}']\n")
    b = Builder()
    p, d = b.add(Pendulum("pend"), ViscousDamper("damper"))
    build(p, d, b)
    with pytest.raises(BuildError) as from_objects:
        b.build()
    assert _where_free(str(from_objects.value)) == _where_free(str(from_yaml.value))
    assert "test_python_api.py:" in str(from_objects.value)          # where the builder call was written
    if case == "units":
        assert ("cannot connect pend.theta (numeric shape () float64 [rad]) -> damper.omega (numeric shape () "
                "float64 [rad/s])") in str(from_objects.value)


def test_port_namespaces_complete_and_refuse_unknown_names():
    pend = Pendulum("pend")
    assert dir(pend.out) == ["omega", "theta"] and dir(pend.inp) == ["tau"]
    assert pend.out.theta.ref == "pend.theta"
    with pytest.raises(AttributeError, match="has no output 'thetaa'; did you mean theta"):
        pend.out.thetaa


def test_resources_bind_from_their_provider_as_in_an_assembly(write_yaml):
    b = Builder(dt=0.01, duration=0.05)
    bank = b.add(Bank("bank", values=[2.0, 3.0]))
    scale = Scaler("scale")                     # made without the Gains it uses: bound at build
    assert scale.pending_uses
    b.add(scale)
    b.connect(bank.out.level, scale.inp.u)
    b.record(scale.out.y)
    sim = b.build()
    assert scale.gains is bank.gains and not scale.pending_uses
    np.testing.assert_array_equal(sim["scale.y"], [4.0, 9.0])
    reg = build_registry(load_entry_points=False)
    reg.add_component(Bank), reg.add_component(Scaler)
    yaml = load_session(write_yaml("components:\n  bank: {type: test_gain_bank, params: {values: [2.0, 3.0]}}\n"
                 "  scale: {type: test_scaler}\nconnections: [bank.level -> scale.u]\nrecord: [scale.y]\n"
                 "sim: {dt: 0.01, duration: 0.05}\n"), registry=reg)
    sim.advance_to(0.05)
    assert np.array_equal(sim.log.rows, yaml.run().log.rows)
    assert sim.plan.report["resources"] == yaml.plan.report["resources"] == {"scale": {"gains": "bank"}}
    # two providers: name one, as 'uses:' does
    b = Builder(dt=0.01, duration=0.05)
    a, c = b.add(Bank("a", values=[1.0]), Bank("c", values=[5.0, 6.0]))
    s = b.add(Scaler("scale"), uses={"gains": c})
    b.connect(c.out.level, s.inp.u)
    b.build()
    assert s.gains is c.gains
    b = Builder()
    b.add(Bank("a"), Bank("c"), Scaler("scale"))
    with pytest.raises(ConfigError, match="2 components provide one"):
        b.build()
    # given its resources at construction, a component keeps them
    assert Scaler("alone", uses={"gains": Gains([1.0])}).gains.n == 1


def test_stops_end_the_run_with_their_outcome():
    b = Builder(dt=1e-3, duration=5.0)
    pend = b.add(Pendulum("pend", theta0=0.2, gravity=9.81))
    b.record(pend.out.theta)
    b.stop(pend.out.theta, below=0.0, reason="crossed the bottom", outcome="success")
    sim = b.build()
    summary = sim.advance_to(5.0)
    assert sim.ended and summary["outcome"] == "success" and "crossed the bottom" in summary["stop_reason"]
    quarter = np.pi / 2 / np.sqrt(9.81) * (1 + 0.2 ** 2 / 16)      # a quarter period at 0.2 rad, L = 1 m
    assert quarter <= sim.t < quarter + 2e-3
    with pytest.raises(SnakesimError, match="the run ended at t = .*reset\\(\\) to start again"):
        sim.step()
    sim.reset()
    assert not sim.ended and sim.t == 0.0
    with pytest.raises(ConfigError, match="exactly one of above, below, abs_above"):
        b.stop(pend.out.theta, above=1.0, below=0.0)


def test_a_component_belongs_to_one_build_and_the_builder_refuses_strangers():
    b = Builder()
    pend = b.add(Pendulum("pend"))
    b.build()
    with pytest.raises(BuildError, match="already part of a built simulation"):
        Builder().add(pend)
    b = Builder()
    b.add(Pendulum("pend"))
    b.record(Pendulum("other").out.theta)
    with pytest.raises(BuildError, match="'other' was not added to this builder"):
        b.build()
    with pytest.raises(BuildError, match="two components are named 'pend'"):
        Builder().add(Pendulum("pend"), Pendulum("pend"))


def test_integrator_by_name_with_params_or_as_an_object():
    from snakesim.framework.integrators.rk4 import RK4

    s1, _ = pendulum(integrator={"name": "rk4", "params": {}})
    s2, _ = pendulum(integrator=RK4())
    s1.advance_to(0.1), s2.advance_to(0.1)
    assert np.array_equal(s1.log.rows, s2.log.rows) and s2.integrator.name == "rk4"
    with pytest.raises(ConfigError, match="sim.dt"):
        Builder(dt=-1.0)


def test_a_scene_loaded_from_yaml_with_an_open_input(write_yaml, registry):
    path = write_yaml(PENDULUM_YAML)
    sim = load(path, open=["pend.tau"], registry=registry)
    assert "pend.tau" not in {str(d) for d in sim.plan.sources}      # the scene's wire into it is gone
    sim.set_input("pend.tau", 0.1)
    sim.advance_to(0.5)
    assert sim.summary["steps"] == 500 and sim.value("pend.tau") == 0.1
    r = sim.run()                               # from the initial state, the configured duration
    assert r.summary["completed"] and r.summary["steps"] == 2000
