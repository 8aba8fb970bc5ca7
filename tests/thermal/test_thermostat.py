"""Thermostat: holds the set-point, bounded by its power, warns when the set-point cannot melt ice;
thermocouple: seeded, reproducible noise around the true temperature."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from snakesim.components.thermal import ScrewHeat, Thermocouple, Thermostat
from snakesim.framework import Harness


def test_thermostat_holds_the_set_point_of_a_screw_on_ice_within_its_power():
    heat = Harness(ScrewHeat, {"screws": 1, "initial_temperature": 270.0, "emissivity": 0.0,
                               "convection": 10.0, "environment_temperature": 268.15, "mass": 0.2}, rate=20.0)
    stat = Harness(Thermostat, {"set_point": 288.15, "max_power": 80.0}, rate=20.0)
    powers = []
    for k in range(4000):                           # 200 s out of contact, at 20 Hz
        stat.inputs.temperature = heat.outputs()["temperature"]
        stat.update(k / 20)
        P = stat.outputs()["heater_power"]
        powers.append(P[0])
        heat.inputs.heater_power = P
        heat.update(k / 20)
    assert max(powers) == pytest.approx(80.0) and min(powers) >= 0.0
    assert heat.outputs()["temperature"][0] == pytest.approx(288.15, abs=0.05)
    # steady state: the heater supplies the convection loss h A (T* − T_env)
    A = 2 * np.pi * 0.07 * 0.115
    assert powers[-1] == pytest.approx(10.0 * A * (288.15 - 268.15), rel=2e-2)


def test_set_point_below_the_melting_point_warns_naming_both_keys():
    with pytest.warns(UserWarning, match="set_point = 270 K.*melting_point"):
        Thermostat("stat", {"set_point": 270.0}, rate=10.0)


@pytest.mark.parametrize("key, value", [("max_power", -1.0), ("set_point", -3.0)])
def test_bad_thermostat_parameters_name_the_key(key, value):
    with pytest.raises(ValidationError, match=key):
        Thermostat("stat", {key: value}, rate=10.0)


def test_thermocouple_noise_is_seeded_and_centred():
    def readings(seed):
        tc = Harness(Thermocouple, {"n": 3, "noise": 0.5, "seed": seed}, rate=10.0)
        tc.inputs.temperature = [280.0, 290.0, 300.0]
        out = []
        for k in range(400):
            tc.update(k / 10)
            out.append(tc.outputs()["measured"].copy())
        return np.array(out)

    a, b, c = readings(1), readings(1), readings(2)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    err = a - [280.0, 290.0, 300.0]
    assert np.abs(err.mean(axis=0)).max() < 4 * 0.5 / np.sqrt(400)      # 4 σ of the mean
    assert err.std() == pytest.approx(0.5, rel=0.1)
    with pytest.raises(ValueError, match="rate"):
        Thermocouple("tc", {"noise": 0.5})
