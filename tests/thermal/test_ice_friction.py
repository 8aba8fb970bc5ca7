"""The ice-friction law against its table (Schulson & Fortt 2012; what is assumed: ice_friction_data.py)
and against the statements of the source's abstract the table was built from."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.thermal import IceFriction
from snakesim.components.thermal.ice_friction import ice_mu
from snakesim.components.thermal.ice_friction_data import CHECK_POINTS, MU_K, SCATTER, SPEEDS, TEMPERATURES
from snakesim.framework import Harness


def test_reproduces_every_table_point_within_the_scatter():
    T, v = np.meshgrid(TEMPERATURES, SPEEDS, indexing="ij")
    assert np.all(np.abs(ice_mu(T, v) - MU_K) <= SCATTER)


@pytest.mark.parametrize("T, v, mu, source", CHECK_POINTS)
def test_reproduces_an_independent_published_point_within_the_scatter(T, v, mu, source):
    # not used to build the table (ice_friction_data.py): 0.197 from the table against 0.15 measured
    assert abs(float(ice_mu(T, v)) - mu) <= SCATTER, source


def test_stays_in_the_measured_range_everywhere():
    # abstract: μk of smooth surfaces from 0.15 to 0.76 over 98–263 K and 5e-8–1e-3 m/s (and clipped outside)
    T = np.linspace(60.0, 300.0, 97)[:, None]
    v = np.logspace(-9, 1, 101)[None, :]
    mu = ice_mu(T, v)
    assert mu.min() >= 0.15 - 1e-12 and mu.max() <= 0.76 + 1e-12


def test_velocity_dependence_has_the_abstracts_shape():
    lo, peak, hi = 1e-6, 1e-5, 1e-3
    for T in (223.0, 263.0):                    # strengthening below ~1e-5..1e-4 m/s, weakening above
        assert ice_mu(T, lo) < ice_mu(T, peak) > ice_mu(T, hi)
    for T in (133.0, 173.0):                    # no significant dependence
        mus = ice_mu(T, SPEEDS)
        assert np.ptp(mus) < SCATTER
    mid = ice_mu(98.0, np.logspace(-6, -4, 5))  # 98 K: flat in the middle, strengthening at both ends
    assert np.ptp(mid) < 1e-12 and ice_mu(98.0, 5e-8) > mid[0] and ice_mu(98.0, 1e-3) > mid[-1]


def test_component_scales_the_material_mu():
    h = Harness(IceFriction, {"n": 2, "mu_material": 0.5, "ice_temperature": 263.0})
    h.inputs.slip_speed = [1e-5, 1e-3]
    out = h.outputs()
    assert out["mu_scale"] == pytest.approx(ice_mu(263.0, [1e-5, 1e-3]) / 0.5)
    h.inputs.ice_temperature = [98.0]
    assert h.outputs()["mu"] == pytest.approx(ice_mu(98.0, [1e-5, 1e-3]))
    h.inputs.ice_temperature = [-1.0]
    with pytest.raises(ValueError, match="ice_temperature"):
        h.outputs()


def test_apply_false_leaves_the_material_mu():
    h = Harness(IceFriction, {"n": 2, "mu_material": 1.5, "apply": False})
    h.inputs.slip_speed = [1e-5, 1e-3]
    out = h.outputs()
    assert (out["mu_scale"] == 1.0).all() and (out["mu"] == 1.5).all()


@pytest.mark.slow
def test_melt_scene_with_ice_friction_gives_the_contact_the_tables_mu():
    """melt-dwell-climb --set ice_friction=true: the μ the contact sees, walls' μ × screw_mu_scale (heat.mu_scale,
    which holds ice.mu_scale from its 100 Hz sample), is the table's at each screw's slip speed and the ice's
    temperature (268.15 K, clipped to the table's 263 K), one sample later."""
    from snakesim.framework.session import load_session

    r = load_session("melt-dwell-climb", overrides=["ice_friction=true"],
                     sim_overrides={"duration": 0.3, "record_rate": 100}).run()
    mu_walls = 1.5
    v, law, scale = r.log["contact.screw_slip_speed"], r.log["ice.mu"], r.log["heat.mu_scale"]
    assert (r.log["heat.temperature"] > 273.15).all()          # heated: no refreeze bond on top of the law's μ
    assert v.max() > 1e-3 and np.ptp(law) > 0.02               # the screws slip at speeds the table spans
    assert law == pytest.approx(ice_mu(263.0, v), abs=1e-12)
    assert mu_walls * scale[1:] == pytest.approx(law[:-1], abs=1e-12)
    assert mu_walls * scale[0] == pytest.approx(mu_walls)      # before the first sample: the walls' μ
