"""screw_heat alone (no robot: a heated block on ice): the energy ledger closes, the melt rate is the
Stefan / melting-probe closed form, nothing melts below T_m, melting stops once the screw has cooled,
and the refreeze bond follows its power law and breaks on motion."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from snakesim.components.thermal import ScrewHeat
from snakesim.components.thermal.heat_step import LEDGER
from snakesim.framework import Harness

RATE = 100.0
RHO, LF, CI, TM = 917.0, 334e3, 2100.0, 273.15


def block(rate=RATE, **params):
    return Harness(ScrewHeat, {"screws": 2, **params}, rate=rate, name="heat")


def run(h, steps, t0=0.0):
    for k in range(steps):
        h.update(t0 + k / RATE)


def ledger(h):
    return dict(zip(LEDGER, h.xd[-len(LEDGER):]))


def test_energy_ledger_closes_to_round_off_over_a_run():
    # every loss on, contact switching, heater and friction varying: in = stored + out to round-off
    h = block(initial_temperature=276.0, ice_temperature=250.0, environment_temperature=200.0,
              convection=8.0, emissivity=0.6, load_exponent=0.25, mass=0.2)   # light: crosses T_m both ways
    rng = np.random.default_rng(5)
    T0 = h.xd[:2].copy()
    for k in range(3000):
        h.inputs.heater_power = rng.uniform(0.0, 40.0, 2)
        h.inputs.slip_power = rng.uniform(0.0, 5.0, 2)
        h.inputs.normal_force = np.where(rng.random(2) < 0.7, rng.uniform(10.0, 150.0, 2), 0.0)
        h.update(k / RATE)
    e = ledger(h)
    C = 0.2 * 900.0
    assert e["stored"] == pytest.approx(C * (h.xd[:2] - T0).sum(), rel=1e-9, abs=1e-6)   # independent of the ledger
    total_in = e["heater_in"] + e["friction_in"]
    assert total_in > 1e3                                # 30 s of ~20 W on two screws
    assert e["to_ice_melting"] > 0 and e["to_cold_ice"] > 0 and e["radiated"] > 0 and e["convected"] > 0
    out = e["stored"] + e["to_ice_melting"] + e["to_cold_ice"] + e["radiated"] + e["convected"]
    assert abs(total_in - out) < 1e-12 * total_in * 3000 ** 0.5 * 10
    assert abs(e["residual"]) < 1e-12 * total_in * 3000 ** 0.5 * 10
    # latent heat is ρ L_f of the melted volume (nothing relaxed: the block never moved)
    area = 0.115 * 0.01
    assert e["latent"] == pytest.approx(RHO * LF * area * h.xd[2:4].sum(), rel=1e-12)


@pytest.mark.parametrize("t_ice", [268.15, 93.15])
def test_melt_rate_of_a_held_block_is_the_stefan_closed_form(t_ice):
    # the heater exactly replaces what the melt film takes at T0, so T stays T0 and the rate is constant
    T0, g, w, L = 303.15, 20000.0, 0.01, 0.115
    G = g * w * L
    h = block(initial_temperature=T0, ice_temperature=t_ice, emissivity=0.0, convection=0.0)
    h.inputs.heater_power = [G * (T0 - TM), 0.0]
    h.inputs.normal_force = [100.0, 100.0]
    run(h, 1000)                                         # 10 s
    assert h.xd[0] == pytest.approx(T0, abs=1e-9)
    v = G * (T0 - TM) / (w * L * RHO * (LF + CI * (TM - t_ice)))   # closed form, written out here
    assert h.xd[2] == pytest.approx(10.0 * v, rel=1e-10)
    assert 1e-4 < v < 1e-2                              # the scale: tenths of mm to cm per second
    assert h.xd[3] > 0 and h.xd[1] < T0                 # the unheated one cools as it melts


def test_nothing_melts_below_the_melting_point():
    h = block(initial_temperature=272.0, ice_temperature=250.0, emissivity=0.0)
    h.inputs.heater_power = [30.0, 0.0]                 # not enough to reach T_m against the cold ice
    h.inputs.normal_force = [50.0, 50.0]
    run(h, 2000)
    assert (h.xd[:2] < TM).all()
    assert (h.xd[2:4] == 0.0).all()
    e = ledger(h)
    assert e["to_cold_ice"] > 0 and e["to_ice_melting"] == 0.0 and e["latent"] == 0.0


def test_penetration_stops_once_the_heater_is_off_and_the_screw_has_cooled():
    h = block(initial_temperature=303.15, ice_temperature=263.15, environment_temperature=250.0,
              convection=30.0, emissivity=0.0)
    h.inputs.normal_force = [80.0, 80.0]
    h.inputs.heater_power = [50.0, 50.0]
    run(h, 500)
    h.inputs.heater_power = [0.0, 0.0]
    depth, k = [], 500
    while h.xd[0] >= TM and k < 200000:                 # cools through T_m (convection to 250 K air)
        h.update(k / RATE)
        k += 1
    assert h.xd[0] < TM
    d_cold = h.xd[2]
    assert d_cold > 0
    run(h, 3000, t0=k / RATE)                           # 30 s more, cold and still in contact
    assert h.xd[2] == d_cold                            # not a nanometre more
    # what melted after the heater went off is bounded by the heat the screw held above T_m
    assert ledger(h)["latent"] > 0


def test_refreeze_bond_grows_as_its_power_law_and_breaks_on_motion():
    h = block(initial_temperature=280.0, ice_temperature=260.0, emissivity=0.0, bond_stress_1s=2e3,
              bond_exponent=0.4, mu_reference=1.5, mass=0.1, convection=50.0, environment_temperature=200.0)
    h.inputs.normal_force = [60.0, 60.0]
    run(h, 600)                                         # melts in, then cools below T_m in contact
    assert h.xd[2] > 0 and h.xd[0] < TM
    t_b = h.xd[4]
    assert t_b > 0
    out = h.outputs()
    expected = 1.0 + 2e3 * t_b ** 0.4 * 0.115 * 0.01 / (1.5 * 60.0)
    assert out["mu_scale"][0] == pytest.approx(expected, rel=1e-12)
    run(h, 100, t0=2.0)
    assert h.xd[4] == pytest.approx(t_b + 1.0, abs=1e-9)
    h.inputs.travel_speed = [0.05, 0.0]                 # screw 0 rolls out: the bond breaks, the groove relaxes
    d0 = h.xd[2]
    h.update(3.0)
    assert h.xd[4] == 0.0 and h.xd[5] > 0
    assert h.xd[2] == pytest.approx(d0 * np.exp(-(0.05 - 2e-3) / RATE / 0.05), rel=1e-12)   # less the dead band
    assert h.outputs()["mu_scale"][0] == 1.0


def test_engagement_scale_rises_with_depth_to_the_thread():
    h = block(thread_depth=0.01, engagement_gain=2.0)
    h.xd[2:4] = [0.005, 0.03]
    assert h.outputs()["ev_scale"] == pytest.approx([2.0, 3.0])


def test_penetration_past_its_limit_stops_the_run_naming_the_screw():
    h = block(max_penetration=1e-4, initial_temperature=320.0)
    h.inputs.normal_force = [80.0, 0.0]
    run(h, 200)
    assert h.c._stop.reason is not None and "screw_0" in h.c._stop.reason and "max_penetration" in h.c._stop.reason


@pytest.mark.parametrize("key, value", [("specific_heat", -900.0), ("mass", -1.0), ("contact_conductance", -1.0),
                                        ("initial_temperature", -5.0), ("ice_temperature", 0.0),
                                        ("environment_temperature", -1.0), ("convection", -2.0)])
def test_bad_parameters_are_errors_naming_the_key(key, value):
    with pytest.raises(ValidationError, match=key):
        ScrewHeat("heat", {key: value}, rate=RATE)


def test_negative_heater_power_is_an_error_naming_the_screw():
    h = block()
    h.inputs.heater_power = [10.0, -3.0]
    with pytest.raises(ValueError, match=r"heater_power\[screw_1\] = -3.0 W"):
        h.update(0.0)


def test_needs_a_rate():
    with pytest.raises(ValueError, match="rate"):
        ScrewHeat("heat", {})
