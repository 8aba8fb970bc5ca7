"""The deformable terrain's soil law against closed forms (Bekker plate sinkage, elastic rebound, second
pass), its state (restore, determinism) and its input checks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from snakesim.components.terrain.deformable import DeformableTerrain, SoilSpec
from snakesim.components.terrain.deformable_kernels import press_nodes
from snakesim.components.terrain.spec import load_terrain

SNOW = SoilSpec(k_c=4.37e3, k_phi=196.72e3, n=1.6, cohesion=1.03e3, friction_angle=19.7, janosi_k=0.025,
                elastic_k=5.0e5)
CELL = 0.01
SIDE = 0.2                      # m, the plate (20 × 20 nodes, each standing for one cell of area CELL²)


def make_terrain(soil=SNOW):
    return DeformableTerrain(0.0, (-1.0, -1.0), (2.0, 2.0), CELL, soil, max_tiles=64)


def plate_nodes():
    k = int(round(SIDE / CELL))
    i0 = 90
    ii, jj = np.meshgrid(np.arange(i0, i0 + k), np.arange(i0, i0 + k), indexing="ij")
    return ii.ravel().astype(np.int64), jj.ravel().astype(np.int64)


def plate_force(t, z, commit=False):
    ii, jj = plate_nodes()
    sigma = np.zeros(ii.size)
    st = t.state
    press_nodes(t.grid, t.base_z, t.soil, st.tile_of, st.plastic, st.yield_p, st.lift, st.used, ii, jj,
                np.full(ii.size, z), SIDE, commit, sigma)
    return sigma.sum() * CELL * CELL


def equilibrium(t, load, lo=-0.5, hi=0.0):
    """Plate height where the soil carries ``load`` (bisection on the evaluation, nothing committed)."""
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if plate_force(t, mid) > load:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


LOAD = 200.0     # N on 0.04 m²: 5 kPa
AREA = SIDE * SIDE


def bekker_depth():
    return (LOAD / (AREA * (SNOW.k_c / SIDE + SNOW.k_phi))) ** (1.0 / SNOW.n)


def test_plate_sinks_to_bekker_depth_and_rebounds_by_the_elastic_part():
    t = make_terrain()
    z = equilibrium(t, LOAD)
    assert -z == pytest.approx(bekker_depth(), rel=1e-9)
    plate_force(t, z, commit=True)
    t.state.changed()
    # lifted: the rut keeps the plastic part, z − σ / K_e
    rut = float(t.rut_depth(-0.1 + 0.5 * SIDE, -0.1 + 0.5 * SIDE))
    assert rut == pytest.approx(bekker_depth() - LOAD / AREA / SNOW.elastic_k, rel=1e-9)
    assert plate_force(t, -rut + 1e-6) == 0.0          # just above the rut: unloaded


def test_second_pass_over_the_rut_sinks_less():
    t = make_terrain()
    plate_force(t, equilibrium(t, LOAD), commit=True)
    rut = float(t.rut_depth(0.0, 0.0))
    z2 = equilibrium(t, LOAD)
    # reloading is elastic up to the pressure that made the rut: W / (A K_e) below its floor
    assert -z2 - rut == pytest.approx(LOAD / AREA / SNOW.elastic_k, rel=1e-6)
    assert -z2 - rut < bekker_depth()
    # a heavier load yields again and follows Bekker's curve
    z3 = equilibrium(t, 2 * LOAD)
    assert -z3 == pytest.approx((2 * LOAD / (AREA * (SNOW.k_c / SIDE + SNOW.k_phi))) ** (1 / SNOW.n), rel=1e-9)


def test_query_sees_the_rut_and_the_state_restores():
    t = make_terrain()
    before = t.snapshot()
    plate_force(t, -0.05, commit=True)
    t.state.changed(1.0)
    q = t.query(np.array([[0.0, 0.0, 0.0], [0.9, 0.9, 0.0]]))
    assert q.distance[0] > 0.04 and q.distance[1] == 0.0
    after = t.snapshot()
    t.restore(before)
    assert t.query(np.array([[0.0, 0.0, 0.0]])).distance[0] == 0.0
    t.restore(after)
    assert t.query(np.array([[0.0, 0.0, 0.0]])).distance[0] == q.distance[0]
    assert t.state.version == 3 and t.tiles_used() >= 1


def test_rerun_is_bit_identical():
    outs = []
    for _ in range(2):
        t = make_terrain()
        for z in np.linspace(-0.01, -0.06, 7):
            plate_force(t, z, commit=True)
        outs.append(t.snapshot())
    for k in outs[0]:
        assert np.array_equal(outs[0][k], outs[1][k])


# (old, new, key, the file named): a value bad in itself is named in the soil's file; k_c + k_φ·b > 0 is a
# check against the terrain's cell and size, named at the terrain file's soil key with both values
BAD = [("n: 1.6", "n: 0.0", "n", "bad-snow.yaml"),
       ("friction_angle: 19.7", "friction_angle: 95.0", "friction_angle", "bad-snow.yaml"),
       ("k_c: 4.37e3", "k_c: -1.0e5", "k_c", "snow.yaml")]
TERRAINS = Path(__file__).parents[2] / "terrains"


@pytest.mark.parametrize("old,new,key,named", BAD)
def test_bad_soil_names_file_and_key(tmp_path, old, new, key, named):
    """The snow field's soil is an included file (soils/snow-us.yaml): a bad value in it is named with that
    file and the key; the same value inline in a terrain file, with the terrain file and soil.<key>."""
    from snakesim.framework.errors import SnakesimError

    soil = (TERRAINS / "soils" / "snow-us.yaml").read_text()
    assert old in soil
    (tmp_path / "soils").mkdir()
    (tmp_path / "soils" / "bad-snow.yaml").write_text(soil.replace(old, new))
    field = (TERRAINS / "snow-field.yaml").read_text()
    assert "soils/snow-us.yaml" in field
    (tmp_path / "snow.yaml").write_text(field.replace("soils/snow-us.yaml", "soils/bad-snow.yaml"))
    with pytest.raises(SnakesimError) as e:
        load_terrain(str(tmp_path / "snow.yaml"))
    msg = str(e.value)
    assert named in msg and key in msg
    inline = "\n".join("  " + ln for ln in soil.replace(old, new).splitlines() if ln and not ln.startswith("#"))
    (tmp_path / "inline.yaml").write_text(field.replace("soil: {include: soils/snow-us.yaml}", "soil:\n" + inline))
    with pytest.raises(SnakesimError) as e:
        load_terrain(str(tmp_path / "inline.yaml"))
    msg = str(e.value)
    assert "inline.yaml" in msg and ("soil" if key == "k_c" else f"soil.{key}") in msg


@pytest.mark.parametrize("include,words", [
    ("soils/no-such-soil.yaml", ("snow.yaml", "soil.include", "no-such-soil.yaml")),     # missing
    ("soils/list.yaml", ("list.yaml", "soil", "mapping")),                               # a list, not a mapping
])
def test_a_bad_soil_include_names_the_file_and_key(tmp_path, include, words):
    from snakesim.framework.errors import SnakesimError

    (tmp_path / "soils").mkdir()
    (tmp_path / "soils" / "list.yaml").write_text("- 4.37e3\n- 196.72e3\n")
    field = (TERRAINS / "snow-field.yaml").read_text()
    (tmp_path / "snow.yaml").write_text(field.replace("soils/snow-us.yaml", include))
    with pytest.raises(SnakesimError) as e:
        load_terrain(str(tmp_path / "snow.yaml"))
    msg = str(e.value)
    assert all(w in msg for w in words), msg


@pytest.mark.parametrize("scene,contact,rigid", [("snow-screw-traverse", "terramechanics_contact", "screw_sdf_contact"),
                                                 ("mini-eels-sand-crawl", "soil_body_contact", "body_contact")])
def test_a_soil_contact_on_a_rigid_terrain_names_the_kind_and_the_alternative(scene, contact, rigid):
    from snakesim.framework.errors import SnakesimError
    from snakesim.framework.session import load_session

    s = load_session(scene, overrides=["terrain=flat-ice"], sim_overrides={"duration": 0.02})
    with pytest.raises(SnakesimError) as e:
        s.run()
    msg = str(e.value)
    assert "'plane'" in msg and contact in msg and "deformable" in msg and rigid in msg
