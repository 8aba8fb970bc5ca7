"""Assemblies end to end: the pendulum against its closed form, sub-assembly
repetition, repeated connections, fan-out, pruning, multi-rate, layering."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.framework.errors import BuildError, ConfigError
from snakesim.framework.rates import MAX_PHASES
from snakesim.framework.session import load_session


# -- pendulum vs the damped small-angle solution ----------------------------------

def test_pendulum_matches_damped_small_angle_solution(registry):
    th0, T = 0.02, 10.0
    s = load_session("pendulum", registry=registry, overrides=[f"components.pend.params.theta0={th0}"],
                     sim_overrides={"duration": T, "integrator": "rk4"})
    pend, c = s.plan.components["pend"].p, s.plan.components["damper"].p.c
    assert (pend.theta0, pend.omega0) == (th0, 0.0)
    r = s.run()
    assert r.summary["completed"]
    t, theta = r["t"], r["pend.theta"]
    assert t[-1] == pytest.approx(T)

    w0 = math.sqrt(pend.gravity / pend.length)
    zw = c / (2 * pend.mass * pend.length ** 2)              # ζω₀, from 2ζω₀ = c/(mL²)
    wd = math.sqrt(w0 ** 2 - zw ** 2)
    exact = th0 * np.exp(-zw * t) * (np.cos(wd * t) + zw / wd * np.sin(wd * t))

    # Tolerance, from the model:
    # * sin θ = θ − θ³/6 + …: the cubic term lowers the frequency by a relative
    #   θa²/16 (Lindstedt–Poincaré; θa ≤ θ0 is the decaying amplitude), so the
    #   phase lags by at most ω0·t·θ0²/16 and θ by at most θ0·ω0·T·θ0²/16 at T;
    #   the same term adds a third harmonic of amplitude θ0³/192.
    # * RK4 on a linear oscillator: phase error per step ≤ (ω0h)⁵/120, over
    #   T/h steps at most θ0·T·ω0⁵h⁴/120.
    # A factor 1.5 covers the O(θ0⁵) terms and the damping's effect on both.
    h = s.resolved.sim.dt
    nonlinear = th0 * (w0 * T * th0 ** 2 / 16 + th0 ** 2 / 192)
    integrator = th0 * T * w0 ** 5 * h ** 4 / 120
    tol = 1.5 * (nonlinear + integrator)
    err = np.abs(theta - exact)
    assert err.max() < tol
    # the bound is not vacuous: a 2 % error in the damping rate would break it
    wrong = th0 * np.exp(-1.02 * zw * t) * (np.cos(wd * t) + zw / wd * np.sin(wd * t))
    assert np.abs(wrong - exact).max() > tol
    # damper output is τ = −c ω
    np.testing.assert_allclose(r["damper.tau"], -c * r["pend.omega"], rtol=0, atol=1e-15)


# -- sub-assembly repetition -----------------------------------------------------------

def _chain(registry, n, **kw):
    names = ["mass0"] + [f"cell{i}/mass" for i in range(1, n)]
    rec = "[" + ", ".join(f"{m}.x, {m}.v" for m in names) + "]"
    s = load_session("mass-spring-chain", registry=registry, overrides=[f"n={n}", f"record={rec}"], **kw)
    return s, names


@pytest.mark.parametrize("n", [2, 4, 7])
def test_chain_repetition_builds_n_masses_and_conserves_momentum(registry, n):
    s, names = _chain(registry, n, sim_overrides={"duration": 2.0})
    comps = s.plan.components
    assert len(comps) == 2 * n - 1
    assert sorted(comps) == sorted(names + [f"cell{i}/spring" for i in range(1, n)])
    assert all(comps[f"cell{i}/mass"].p.x0 == i for i in range(1, n))
    assert s.report()["state_size"]["continuous"] == 2 * n
    assert s.report()["connections"] == 3 * (n - 1) + 3 * (n - 1)
    r = s.run()
    m = np.array([comps[name].p.mass for name in names])
    x = np.column_stack([r[f"{name}.x"] for name in names])
    v = np.column_stack([r[f"{name}.v"] for name in names])
    # internal forces cancel exactly: p(0) = 0 stays 0 up to round-off; with p = 0 the
    # centre of mass cannot move
    p = v @ m
    com = x @ m / m.sum()
    assert np.abs(p).max() < 1e-12
    assert np.abs(com - com[0]).max() < 1e-12
    assert com[0] == pytest.approx((0.1 + sum(range(1, n))) / n, rel=1e-15)
    # ... and the chain really moves
    assert np.ptp(x[:, 0]) > 0.05


def test_repeated_connections(scene):
    s = scene("""
        sim: {duration: 0.002}
        parameters: {n: 4}
        components:
          src: {type: constant, params: {value: 2.0}}
          g0: {type: gain, params: {k: 1.0}}
          g1: {type: gain, params: {k: 2.0}}
          g2: {type: gain, params: {k: 3.0}}
          g3: {type: gain, params: {k: 4.0}}
        connections:
          - src.y -> g0.u
          - {repeat: "${n - 1}", connect: "g${i}.y -> g${i+1}.u"}
        record: ["g${n - 1}.y"]
        """)
    assert [(a, b) for a, b, _ in s.resolved.connections] == [
        ("src.y", "g0.u"), ("g0.y", "g1.u"), ("g1.y", "g2.u"), ("g2.y", "g3.u")]
    assert s.run()["g3.y"][0] == 2.0 * 1 * 2 * 3 * 4


def test_repeat_zero_adds_nothing(scene):
    s = scene("""
        sim: {duration: 0.002}
        components:
          src: {type: constant, params: {value: 2.0}}
          g0: {type: gain}
        connections:
          - src.y -> g0.u
          - {repeat: 0, connect: "g${i}.y -> nowhere.u"}
        record: [g0.y]
        """)
    assert len(s.resolved.connections) == 1


def test_fan_out(scene):
    s = scene("""
        sim: {duration: 0.1}
        components:
          src: {type: sine, params: {frequency: 2.0, amplitude: 1.5}}
          a: {type: gain, params: {k: 2.0}}
          b: {type: gain, params: {k: -3.0}}
        connections:
          - src.y -> a.u, b.u
        record: [src.y, a.y, b.y]
        """)
    assert [(x, y) for x, y, _ in s.resolved.connections] == [("src.y", "a.u"), ("src.y", "b.u")]
    r = s.run()
    t = r["t"]
    np.testing.assert_allclose(r["src.y"][:, 0], 1.5 * np.sin(2 * np.pi * 2.0 * t), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(r["a.y"], 2.0 * r["src.y"])
    np.testing.assert_array_equal(r["b.y"], -3.0 * r["src.y"])


def test_pruning_drops_dead_branches_and_keeps_recorded_and_sinks(scene):
    s = scene("""
        sim: {duration: 0.01}
        components:
          src: {type: constant, params: {value: 1.0}}
          kept: {type: gain}
          dead1: {type: gain}
          dead2: {type: gain}
          feeds_sink: {type: gain}
          sink: {type: test_stopper, params: {t_stop: 100.0}}
          lonely: {type: sine}
        connections:
          - src.y -> kept.u, dead1.u, feeds_sink.u
          - dead1.y -> dead2.u
          - feeds_sink.y -> sink.u
        record: [kept.y]
        """)
    rep = s.report()
    assert sorted(rep["pruned"]) == ["dead1", "dead2", "lonely"]
    assert sorted(rep["components"]) == ["feeds_sink", "kept", "sink", "src"]
    assert s.run()["kept.y"][-1] == 1.0
    # pruning is a build decision: the saved configuration still has every component
    assert "dead2" in s.config_dict()["components"]


# -- multi-rate ---------------------------------------------------------------------------

def test_zero_order_hold_updates_every_ten_base_steps(scene):
    s = scene("""
        sim: {duration: 0.2, dt: 0.001}
        components:
          src: {type: sine, params: {frequency: 3.0}}
          zoh: {type: zero_order_hold, rate: 100}
          fast: {type: zero_order_hold, rate: 250}
        connections:
          - src.y -> zoh.u, fast.u
        record: [src.y, zoh.y, fast.y]
        """)
    rep = s.report()
    assert rep["components"]["zoh"]["period_steps"] == 10
    assert rep["components"]["fast"]["period_steps"] == 4
    assert rep["phases"] == 20 and rep["rates_hz"] == [100.0, 250.0]
    r = s.run()
    u, y, yf = r["src.y"][:, 0], r["zoh.y"][:, 0], r["fast.y"][:, 0]
    k = np.arange(u.size)
    for period, out in ((10, y), (4, yf)):
        # the output at step k is the input sampled at the previous tick (a unit delay of one period)
        tick = (k // period - 1) * period
        expected = np.where(tick >= 0, u[np.maximum(tick, 0)], 0.0)
        np.testing.assert_array_equal(out, expected)
        changes = np.flatnonzero(np.diff(out)) + 1
        assert changes.size > 0 and np.all(changes % period == 0)


def test_too_many_phases(scene):
    # periods 64 and 65 base steps: their least common multiple is 4160 > MAX_PHASES
    assert 64 * 65 > MAX_PHASES
    with pytest.raises(BuildError) as e:
        scene(f"""
            sim: {{dt: 0.001}}
            components:
              src: {{type: constant}}
              a: {{type: zero_order_hold, rate: {1 / (64 * 0.001)!r}}}
              b: {{type: zero_order_hold, rate: {1 / (65 * 0.001)!r}}}
            connections:
              - src.y -> a.u, b.u
            """)
    msg = str(e.value)
    assert f"4160 distinct tick patterns (> {MAX_PHASES})" in msg and "[1, 64, 65]" in msg


# -- layering precedence ---------------------------------------------------------------------

def test_layering_precedence(registry, write_yaml):
    c1 = write_yaml("""
        sim: {dt: 0.002, duration: 0.5}
        parameters: {damping: 0.2}
        components:
          pend: {params: {length: 2.0, mass: 3.0}}
        """, "c1.yaml")
    c2 = write_yaml("""
        sim: {dt: 0.004}
        components:
          pend: {params: {length: 3.0}}
        """, "c2.yaml")

    def built(**kw):
        s = load_session("pendulum", registry=registry, **kw)
        return s.plan.components["pend"].p, s.plan.components["damper"].p, s.resolved.sim

    p, d, sim = built()
    assert (p.gravity, p.theta0) == (9.81, 0.2)              # Params default, assembly value
    assert (p.length, p.mass, d.c, sim.dt, sim.duration) == (1.0, 1.0, 0.05, 0.001, 10.0)

    p, d, sim = built(config_files=[c1])
    assert (p.length, p.mass, d.c, sim.dt, sim.duration) == (2.0, 3.0, 0.2, 0.002, 0.5)
    assert (p.gravity, p.theta0) == (9.81, 0.2)

    p, d, sim = built(config_files=[c1, c2])                 # later file wins, key by key
    assert (p.length, p.mass, d.c, sim.dt, sim.duration) == (3.0, 3.0, 0.2, 0.004, 0.5)

    p, d, sim = built(config_files=[c2, c1])
    assert (p.length, sim.dt) == (2.0, 0.002)

    p, d, sim = built(config_files=[c1, c2],
                      overrides=["components.pend.params.length=4.0", "damping=0.3", "sim.dt=0.005"])
    assert (p.length, p.mass, d.c, sim.dt, sim.duration) == (4.0, 3.0, 0.3, 0.005, 0.5)

    p, d, sim = built(config_files=[c1, c2], overrides=["sim.dt=0.005", "sim.dt=0.01", "parameters.damping=0.4"],
                      sim_overrides={"dt": 0.02, "duration": None})
    assert (d.c, sim.dt, sim.duration) == (0.4, 0.02, 0.5)   # None: flag not given, file value kept


def test_integrator_layers_combine(registry, write_yaml):
    path = write_yaml("""
        sim: {duration: 0.01, integrator: dopri5}
        components:
          pend: {type: pendulum}
        """)
    s = load_session(path, registry=registry, overrides=["sim.integrator.params.rtol=1e-9"])
    assert s.integrator.name == "dopri5" and s.integrator.p.rtol == 1e-9
    cfg = write_yaml("sim: {integrator: {name: rosenbrock2, params: {jacobian_every: 3}}}\n", "cfg.yaml")
    s = load_session(path, registry=registry, config_files=[cfg], overrides=["sim.integrator.params.fd_eps=1e-6"])
    assert s.integrator.name == "rosenbrock2" and (s.integrator.p.jacobian_every, s.integrator.p.fd_eps) == (3, 1e-6)
    s = load_session(path, registry=registry, config_files=[cfg], sim_overrides={"integrator": "rk4"})
    assert s.integrator.name == "rk4" and s.integrator.p.substeps == 1


def test_nested_parameters_repeated_includes_and_patches(registry, write_yaml):
    write_yaml("""
        parameters:
          robot: {modules: 2, gain: 1.0}
        components:
          g: {type: gain, params: {k: "${robot.gain}", n: "${robot.modules}"}}
        """, "lib/arm.yaml")
    top = write_yaml("""
        sim: {duration: 0.002}
        parameters:
          robot: {modules: 3, gain: 2.0}
        components:
          src: {type: constant, params: {n: "${robot.modules}", value: 1.0}}
        include:
          - assembly: lib/arm
            as: "arm${i}"
            repeat: 2
            params: {robot: {modules: "${robot.modules}", gain: "${i + robot.gain}"}}
        connections:
          - {repeat: 2, connect: "src.y -> arm${i}/g.u"}
        record: [arm0/g.y, arm1/g.y]
        """)
    patch = write_yaml("components:\n  arm1/g: {params: {k: 10.0}}\n", "patch.yaml")
    s = load_session(top, registry=registry, overrides=["robot.modules=4"])
    comps = s.plan.components
    assert {n: (c.p.k, c.p.n) for n, c in comps.items() if n != "src"} == {"arm0/g": (2.0, 4), "arm1/g": (3.0, 4)}
    r = s.run()
    np.testing.assert_array_equal(r["arm0/g.y"][0], [2.0] * 4)
    np.testing.assert_array_equal(r["arm1/g.y"][0], [3.0] * 4)
    s = load_session(top, registry=registry, config_files=[patch])
    assert s.plan.components["arm1/g"].p.k == 10.0 and s.plan.components["arm1/g"].p.n == 3
    assert s.plan.components["arm0/g"].p.k == 2.0


def test_patch_of_a_missing_included_component(registry, write_yaml):
    path = write_yaml("""
        include:
          - {assembly: lib/spring-mass-cell, as: cell}
        components:
          cell/sprin: {params: {k: 5.0}}
        """)
    with pytest.raises(ConfigError, match=r"component 'cell/sprin' has no 'type' \(a patch for a component that does not exist\?\)"):
        load_session(path, registry=registry)
