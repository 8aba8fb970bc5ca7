"""The rut on disk: the deformable terrain's state saved and restored (deformable_files.py), its numbers
against the plate's closed form, its picture, and the snow scene's end-of-run report."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.terrain.deformable import DeformableTerrain
from snakesim.components.terrain.deformable_files import load_state, rut_picture, rut_summary, save_state

from test_soil import AREA, CELL, LOAD, SNOW, bekker_depth, equilibrium, make_terrain, plate_force


def pressed():
    t = make_terrain()
    plate_force(t, equilibrium(t, LOAD), commit=True)
    t.state.changed(1.0)
    return t


def test_rut_numbers_are_the_plates_closed_form():
    r = rut_summary(pressed())
    rut = bekker_depth() - LOAD / AREA / SNOW.elastic_k          # plastic part of the Bekker sinkage
    assert r["deformed_nodes"] == round(AREA / CELL ** 2)
    assert r["max_rut_depth_m"] == pytest.approx(rut, rel=1e-9)
    assert r["rut_volume_m3"] == pytest.approx(AREA * rut, rel=1e-9)
    # the plate's nodes: i, j = 90 … 109 of a grid from −1 m at 1 cm
    assert r["rut_bounds_m"] == pytest.approx([-0.1, -0.1, 0.09, 0.09], abs=1e-12)


def test_saved_state_restores_bit_for_bit_and_refuses_another_grid(tmp_path):
    t = pressed()
    path = save_state(t, tmp_path / "rut.npz")
    fresh = make_terrain()
    load_state(fresh, path)
    a, b = t.snapshot(), fresh.snapshot()
    assert all(np.array_equal(a[k], b[k]) for k in a)
    p = np.array([[0.0, 0.0, 0.0]])
    assert fresh.query(p).distance[0] == t.query(p).distance[0] > 0.0
    other = DeformableTerrain(0.0, (-1.0, -1.0), (2.0, 2.0), 2 * CELL, SNOW, max_tiles=64, source="other.yaml")
    with pytest.raises(ValueError, match="rut.npz.*other.yaml"):
        load_state(other, path)


def test_rut_picture_is_a_png(tmp_path):
    assert rut_picture(make_terrain(), tmp_path / "none.png") is None        # nothing deformed: no picture
    path = rut_picture(pressed(), tmp_path / "rut.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
