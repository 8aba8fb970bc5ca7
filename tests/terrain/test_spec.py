"""YAML definitions, lookup by name, error messages, the terrain component."""

import numpy as np
import pytest

from snakesim.components.terrain import Terrain, TerrainSource, available_terrains, build_terrain, load_terrain
from snakesim.framework import ConfigError, Harness

SHIPPED = ["flat-ice", "tilted-plane-20deg", "tube-r0.3", "rough-tube", "parallel-walls-0.35", "u-channel",
           "moulin", "fractal-dem", "box-channel"]


def test_all_shipped_terrains_load_and_answer():
    assert set(SHIPPED) <= set(available_terrains())
    p = np.random.default_rng(1).uniform(-0.5, 0.5, (100, 3))
    for name in SHIPPED:
        t = load_terrain(name)
        q = t.query(p)
        assert q.distance.shape == (100,) and q.closest.shape == (100, 3)
        assert np.isfinite(q.distance).all()
        np.testing.assert_allclose(np.linalg.norm(q.normal, axis=1), 1.0)
        assert q.material.min() >= 0 and q.material.max() < len(t.materials)


def test_unknown_name_suggests_close_match():
    with pytest.raises(ConfigError, match=r"no terrain 'tube-r0\.4'.*Did you mean: tube-r0\.3"):
        load_terrain("tube-r0.4")


def test_missing_path():
    with pytest.raises(ConfigError, match="no terrain 'some/where.yaml'"):
        load_terrain("some/where.yaml")


def test_bad_key_names_file_line_and_valid_keys(tmp_path):
    f = tmp_path / "t.yaml"
    f.write_text("kind: tube\nradious: 0.3\n")
    with pytest.raises(ConfigError, match=r"t\.yaml:2: radious: unknown key 'radious'; did you mean 'radius'\? valid keys: "):
        load_terrain(str(f))


def test_bad_kind_and_bad_value(tmp_path):
    f = tmp_path / "k.yaml"
    f.write_text("kind: volcano\n")
    with pytest.raises(ConfigError, match="k.yaml.*'plane'"):
        load_terrain(str(f))
    f.write_text("kind: tube\nradius: -1\n")
    with pytest.raises(ConfigError, match=r"k\.yaml:2: radius: .*greater than 0"):
        load_terrain(str(f))
    f.write_text("kind: tube\nradius: 0.3\nmaterials:\n  - {name: ice, mu: -1}\n")
    with pytest.raises(ConfigError, match=r"k\.yaml:4: materials\.0\.mu"):
        load_terrain(str(f))


def test_region_and_material_names_checked():
    with pytest.raises(ConfigError, match="unknown region 'roof'.*walls, floor"):
        build_terrain({"kind": "u_channel", "width": 0.4, "regions": {"roof": "ice"}})
    with pytest.raises(ConfigError, match="unknown material 'rock'"):
        build_terrain({"kind": "u_channel", "width": 0.4, "regions": {"floor": "rock"}})


def test_roughness_larger_than_radius_is_an_error():
    with pytest.raises(ConfigError, match="radius"):
        build_terrain({"kind": "tube", "radius": 0.01, "roughness": {"rms": 0.05}})


def test_materials_carry_contact_parameters():
    t = load_terrain("u-channel")
    floor = t.materials[t.region_material[t.regions.index("floor")]]
    assert (floor.name, floor.k, floor.c, floor.mu) == ("dirty-ice", 1.5e5, 1.5e3, 0.4)


def test_terrain_component_outputs_the_terrain():
    out = Harness(TerrainSource, {"name": "u-channel"}).outputs()
    assert isinstance(out["terrain"], Terrain) and out["terrain"].name == "u-channel"
    assert TerrainSource.type_name == "terrain" and not TerrainSource.inputs
    inline = Harness(TerrainSource, {"spec": {"kind": "plane", "origin": [0, 0, 1]}}).outputs()["terrain"]
    assert inline.distance([[0, 0, 3]])[0] == pytest.approx(2.0)
    with pytest.raises(ConfigError, match="Did you mean"):
        Harness(TerrainSource, {"name": "flat-ic"})
