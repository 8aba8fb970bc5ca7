"""The soil's books: the energy a body loses to it against the work its state says was done, determinism,
and a saved state that a later terrain starts from (``initial_state``) continuing bit for bit.

Energy. A node's law (deformable_kernels.py) loads along Bekker's curve σ_B = k sⁿ (k = k_c/b + k_φ)
while it flows and is elastic (stiffness K_e) below its yield memory σ_y; so from its state alone
(s_p, σ_y, the deepest sinkage s_max = s_p + σ_y/K_e) the work it has absorbed for good is

    D = A [k s_max^(n+1) / (n+1) − σ_y² / (2 K_e)]        (the plastic work: Bekker's area less the rebound)

and it holds E_el = A K_e (s − s_p)² / 2 while pressed to s > s_p. A plate dropped on the snow, integrated
here (semi-implicit Euler, the soil's loads committed every step as the contact's check does), must have
lost m g Δh − ½ m v² = Σ (D + E_el) up to the integrator's error: first order in the step, so the gap
halves with it (a bookkeeping error would not). The volume: the model compacts (no bulldozing, as SCM with
its bulldozing off), so the rut's volume Σ s_p A is soil pressed denser in place, its mass unchanged; the
plate's rut volume is its area times the plastic sinkage (test_rut_files.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from snakesim.components.terrain.spec import load_terrain
from snakesim.components.terramechanics.wheel import RigidWheel, wheel_forces
from snakesim.framework.errors import SnakesimError

from test_soil import CELL, LOAD, SIDE, SNOW, make_terrain, plate_force

G = 9.81
H0 = 0.02          # m, the plate's drop height above the virgin snow


def drop(dt, duration=0.8):
    """(energy the plate lost J, the soil's D + E_el J) after a drop from H0."""
    t = make_terrain()
    m, z, v = LOAD / G, H0, 0.0
    for _ in range(int(round(duration / dt))):
        f = plate_force(t, z, commit=True)
        v += (f / m - G) * dt
        z += v * dt
    snap = t.snapshot()
    on = snap["plastic"] > 0.0
    s_p, s_y = snap["plastic"][on], snap["yield_p"][on]
    k, n, ke, area = SNOW.k_c / SIDE + SNOW.k_phi, SNOW.n, SNOW.elastic_k, CELL * CELL
    s_max = s_p + s_y / ke
    plastic_work = area * (k * s_max ** (n + 1) / (n + 1) - s_y ** 2 / (2 * ke)).sum()
    elastic = area * (0.5 * ke * np.maximum(-z - s_p, 0.0) ** 2).sum()
    assert on.sum() == round(SIDE * SIDE / CELL ** 2)
    return m * G * (H0 - z) - 0.5 * m * v * v, plastic_work + elastic, plastic_work


def test_energy_lost_by_a_dropped_plate_is_the_soils_plastic_plus_elastic_work():
    lost1, soil1, d1 = drop(2e-4)
    lost2, soil2, d2 = drop(1e-4)
    gap1, gap2 = lost1 - soil1, lost2 - soil2
    assert abs(gap1) < 1e-3 * lost1
    assert 0.4 < gap2 / gap1 < 0.6                       # first order: the integrator's, not the books'
    assert d2 > 0.9 * lost2                              # most of it went into the rut for good
    assert soil2 - d2 > 0.0                              # and the plate is still pressing the soil elastically


WHEEL = RigidWheel(radius=0.2, width=0.1)


def drive(t, steps, start=0):
    """A wheel rolling along +x over the terrain, committing every 1 cm, sinking 2 → 4 cm; the forces."""
    out = []
    for k in range(start, start + steps):
        z0 = 0.02 + 0.02 * k / 40
        r = wheel_forces(t, WHEEL, (-0.3 + 0.01 * k, 0.003, WHEEL.radius - z0), 0.0, 0.25, commit=True)
        out.append((r["drawbar_pull"], r["load"], r["torque"]))
    return np.array(out)


def snow_file(tmp_path, extra=""):
    text = (Path(__file__).parents[2] / "terrains" / "snow-field.yaml").read_text()
    path = tmp_path / "snow.yaml"
    path.write_text(text + extra)
    return path


def test_a_run_from_a_saved_state_continues_bit_identically(tmp_path):
    from snakesim.components.terrain.deformable_files import save_state

    whole = load_terrain(str(snow_file(tmp_path)))
    forces = drive(whole, 40)
    again = load_terrain(str(snow_file(tmp_path)))
    assert np.array_equal(drive(again, 40), forces)                  # deterministic
    first = load_terrain(str(snow_file(tmp_path)))
    head = drive(first, 25)
    save_state(first, tmp_path / "soil_state.npz")
    later = load_terrain(str(snow_file(tmp_path, "initial_state: soil_state.npz\n")))
    assert later.state.version == 1 and later.tiles_used() == first.tiles_used()
    tail = drive(later, 15, start=25)
    assert np.array_equal(np.vstack([head, tail]), forces)
    a, b = whole.snapshot(), later.snapshot()
    assert all(np.array_equal(a[k], b[k]) for k in a)
    assert np.any(a["plastic"] > 0.0)


def test_initial_state_of_another_grid_or_no_file_names_the_key(tmp_path):
    from snakesim.components.terrain.deformable_files import save_state

    t = make_terrain()                       # a 2 m patch at 1 cm, not the snow field's
    plate_force(t, -0.05, commit=True)
    save_state(t, tmp_path / "other.npz")
    for state, words in (("other.npz", "grid"), ("missing.npz", "no file")):
        with pytest.raises(SnakesimError) as e:
            load_terrain(str(snow_file(tmp_path, f"initial_state: {state}\n")))
        msg = str(e.value)
        assert "snow.yaml" in msg and "initial_state" in msg and words in msg and state in msg
