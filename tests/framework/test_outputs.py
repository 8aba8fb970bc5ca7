"""Recording and run outputs: signals.csv, summary.json, config.yaml round trip,
determinism, record_rate and stop conditions."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from snakesim.framework.errors import BuildError
from snakesim.framework.session import load_session


def read_csv(path):
    with open(path) as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array(rows[1:], dtype=float)


def test_run_writes_signals_summary_and_config(scene, tmp_path):
    s = scene("""
        sim: {duration: 0.05, dt: 0.01}
        components:
          src: {type: constant, params: {value: [1.0, 2.0, 3.0], n: 3}}
          xy: {type: test_planar}
          pend: {type: pendulum, params: {theta0: 0.3}}
        record: [pend.theta, src.y, xy.p_xy]
        """)
    out = tmp_path / "run"
    r = s.run(out_dir=out)
    header, data = read_csv(out / "signals.csv")
    assert header == ["t", "pend.theta", "src.y[0]", "src.y[1]", "src.y[2]", "xy.p_xy.x", "xy.p_xy.y"]
    np.testing.assert_allclose(data[:, 0], np.arange(6) * 0.01, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(data[:, 2:5], np.tile([1.0, 2.0, 3.0], (6, 1)))
    np.testing.assert_array_equal(data[:, 5], data[:, 0])
    np.testing.assert_array_equal(data[:, 6], -data[:, 0])
    np.testing.assert_array_equal(data, r.log.rows)                 # 17 digits: exact round trip
    assert data[0, 1] == 0.3

    summary = json.loads((out / "summary.json").read_text())
    assert summary["sim_time_s"] == pytest.approx(0.05)
    assert summary["steps"] == 5
    assert summary["stop_reason"] == "duration reached" and summary["completed"] is True
    assert summary["wall_time_s"] > 0
    assert summary["real_time_factor"] == pytest.approx(summary["sim_time_s"] / summary["wall_time_s"])
    assert summary["integrator"]["name"] == "rk4"
    assert "last_good_state_file" not in summary
    assert not (out / "last_good_state.npz").exists()


def test_saved_config_reproduces_the_run_bit_for_bit(registry, tmp_path):
    a = tmp_path / "a"
    s = load_session("mass-spring-chain", registry=registry, overrides=["n=3", "k=50"],
                     sim_overrides={"duration": 0.5, "integrator": "dopri5"})
    s.run(out_dir=a)
    cfg = (a / "config.yaml").read_text()
    assert "${" not in cfg and "include: []" in cfg
    s2 = load_session(a / "config.yaml", registry=registry)
    assert s2.plan.components["cell2/spring"].p.k == 50
    assert s2.integrator.name == "dopri5" and s2.integrator.p == s.integrator.p
    assert s2.config_dict() == s.config_dict()
    b = tmp_path / "b"
    s2.run(out_dir=b)
    assert (b / "signals.csv").read_bytes() == (a / "signals.csv").read_bytes()


def test_two_runs_are_bit_identical(registry, tmp_path):
    kw = dict(registry=registry, sim_overrides={"duration": 1.0})
    load_session("pendulum", **kw).run(out_dir=tmp_path / "a")
    load_session("pendulum", **kw).run(out_dir=tmp_path / "b")
    assert (tmp_path / "a" / "signals.csv").read_bytes() == (tmp_path / "b" / "signals.csv").read_bytes()


@pytest.mark.parametrize("integrator", ["rk4", "dopri5", "rosenbrock2"])
def test_one_session_runs_twice_from_the_initial_state(registry, tmp_path, integrator):
    s = load_session("pendulum", registry=registry, sim_overrides={"duration": 0.5, "integrator": integrator})
    s.run(out_dir=tmp_path / "a")
    s.run(out_dir=tmp_path / "b")
    assert (tmp_path / "a" / "signals.csv").read_bytes() == (tmp_path / "b" / "signals.csv").read_bytes()


def test_record_rate_decimates(scene):
    s = scene("""
        sim: {duration: 0.1, dt: 0.001, record_rate: 100}
        components:
          pend: {type: pendulum}
        record: [pend.theta]
        """)
    t = s.run()["t"]
    np.testing.assert_allclose(t, np.arange(11) * 0.01, rtol=0, atol=1e-15)


def test_bad_record_rate(scene):
    with pytest.raises(BuildError, match="record_rate 300 Hz is not an integer number of base steps"):
        scene("""
            sim: {duration: 0.1, dt: 0.001, record_rate: 300}
            components:
              pend: {type: pendulum}
            """)


def test_recording_a_structured_port_is_refused(scene):
    with pytest.raises(BuildError, match="record w.w .*only numeric ports can be recorded"):
        scene("""
            components:
              w: {type: test_wrench_source}
            record: [w.w]
            """)


def test_structured_values_flow_through_an_assembly(scene):
    s = scene("""
        sim: {duration: 0.01, dt: 0.001}
        components:
          w: {type: test_wrench_source}
          f: {type: test_wrench_to_force}
        connections: [w.w -> f.w]
        record: [f.force]
        """)
    r = s.run()
    np.testing.assert_allclose(r["f.force"], 2.0 * r["t"], rtol=1e-15)


def test_stop_condition_ends_the_run_with_its_reason(scene):
    s = scene("""
        sim: {duration: 2.0, dt: 0.001}
        components:
          pend: {type: pendulum, params: {theta0: 0.1, length: 1.0, gravity: 9.81}}
        record: [pend.theta]
        stop:
          - {signal: pend.theta, below: 0.0, reason: "crossed the vertical"}
        """)
    r = s.run()
    sm = r.summary
    assert not sm["completed"]
    assert sm["stop_reason"].startswith("stop condition: crossed the vertical at t = ")
    theta, t = r["pend.theta"], r["t"]
    assert theta[-1] < 0 and np.all(theta[:-1] >= 0)          # stopped at the first crossing, recorded
    # a small-angle pendulum first crosses zero a quarter period in: (π/2)·sqrt(L/g)
    quarter = math.pi / 2 * math.sqrt(1.0 / 9.81)
    assert t[-1] == pytest.approx(quarter, abs=0.002)            # θ0 = 0.1 lengthens it by θ0²/16 < 0.1 %
    assert sm["t_end_s"] == t[-1] and sm["steps"] == t.size - 1


def test_stop_condition_index_and_abs_above(scene):
    s = scene("""
        sim: {duration: 1.0, dt: 0.01}
        components:
          xy: {type: test_planar}
        record: [xy.p_xy]
        stop:
          - {signal: xy.p_xy, index: 1, abs_above: 0.25}
        """)
    r = s.run()
    assert r.summary["stop_reason"].startswith("stop condition: xy.p_xy1 abs above 0.25 at t = 0.26")
    assert r["t"][-1] == pytest.approx(0.26)


def test_stop_condition_index_out_of_range(scene):
    with pytest.raises(BuildError, match="index 5 out of range for 2 elements"):
        scene("""
            components:
              xy: {type: test_planar}
            stop:
              - {signal: xy.p_xy, index: 5, above: 1}
            """)


def test_component_stop_ends_the_run(scene):
    s = scene("""
        sim: {duration: 1.0, dt: 0.01}
        components:
          src: {type: constant}
          stopper: {type: test_stopper, params: {t_stop: 0.25}}
        connections: [src.y -> stopper.u]
        record: [src.y]
        """)
    # update() asks at t = 0.25 s; that step completes and the run ends at the next tick
    r = s.run()
    assert r.summary["stop_reason"] == "stopper: mission complete at t = 0.26 s"
    assert not r.summary["completed"]
    assert r["t"][-1] == pytest.approx(0.26)
    # the flag is reset for the next run: it stops at the same place again
    assert s.run().summary["stop_reason"] == "stopper: mission complete at t = 0.26 s"


def test_integrator_statistics_are_per_run(registry):
    s = load_session("pendulum", registry=registry, sim_overrides={"duration": 0.1, "integrator": "rk4"})
    for _ in range(2):
        st = s.run().summary["integrator"]
        # 100 steps; the first stage of each comes from the simulator's output pass
        assert (st["steps"], st["f_evals"]) == (100, 300)


def test_non_finite_discrete_state_is_a_named_stop(scene, tmp_path):
    s = scene("""
        sim: {duration: 0.1, dt: 0.001}
        components:
          src: {type: step, params: {initial: 0.1, value: 1.0e308, t_step: 0.02}}
          big: {type: gain, params: {k: 10.0}}          # 1e308 * 10 overflows to inf (an inf parameter is refused)
          zoh: {type: zero_order_hold, rate: 100}
        connections: [src.y -> big.u, big.y -> zoh.u]
        record: [zoh.y]
        """)
    r = s.run(out_dir=tmp_path)
    # the hold samples inf at its tick t = 0.02 s
    assert r.summary["stop_reason"].startswith("non-finite state in component 'zoh' after t = 0.02 s")
    assert "discrete" in r.summary["stop_reason"]
    np.testing.assert_array_equal(r.last_good_state["XD"], [1.0])
    assert r.last_good_state["t"] == pytest.approx(0.02)
    assert (tmp_path / "last_good_state.npz").exists()
