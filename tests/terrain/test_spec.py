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


# -- materials files: {include: FILE} --------------------------------------------------

FITTED = """# as `snakesim fit-friction --out` writes it
materials:
  - name: hard_ice
    k: 120000.0
    c: 900.0
    mu: 0.25
    ev_a: 1.8
    ev_b: 0.025    # 1/N
"""


def _terrain_with_include(tmp_path, fitted=FITTED, entry="{include: mats/hard-ice.yaml}"):
    (tmp_path / "mats").mkdir(exist_ok=True)
    (tmp_path / "mats" / "hard-ice.yaml").write_text(fitted)
    t = tmp_path / "walls.yaml"
    t.write_text("kind: u_channel\nwidth: 0.4\nmaterials:\n  - {name: rock, k: 1.0e6, c: 2000, mu: 0.6}\n"
                 f"  - {entry}\nregions: {{floor: hard_ice}}\n")
    return t


def test_materials_file_is_included_relative_to_the_terrain_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path / ".." )                 # not the terrain's folder
    t = load_terrain(str(_terrain_with_include(tmp_path)))
    assert [m.name for m in t.materials] == ["rock", "hard_ice"]      # spliced in where the entry stands
    floor = t.materials[t.region_material[t.regions.index("floor")]]
    assert (floor.k, floor.c, floor.mu, floor.ev_a, floor.ev_b) == (1.2e5, 900.0, 0.25, 1.8, 0.025)
    assert t.materials[t.region_material[t.regions.index("walls")]].name == "rock"   # the first is the default


def test_inline_definitions_include_relative_to_the_current_folder(tmp_path, monkeypatch):
    _terrain_with_include(tmp_path)
    monkeypatch.chdir(tmp_path)
    t = load_terrain({"kind": "plane", "materials": [{"include": "mats/hard-ice.yaml"}]})
    assert t.materials[0].name == "hard_ice"


@pytest.mark.parametrize("fitted,entry,match", [
    (FITTED, "{include: mats/soft-ice.yaml}",
     r"walls\.yaml:5: materials\.1\.include: materials file 'mats/soft-ice\.yaml' not found \(looked for .*soft-ice"),
    (FITTED, "{include: mats/hard-ice.yaml, name: x}", r"walls\.yaml:5: materials\.1\.include: .*got also name"),
    (FITTED, "{include: 3}", r"walls\.yaml:5: materials\.1\.include: 'include' names a materials file.*got 3"),
    (FITTED.replace("mu: 0.25", "mu: -0.25"),  "{include: mats/hard-ice.yaml}",
     r"hard-ice\.yaml:6: materials\.0\.mu: material 'hard_ice': mu = -0\.25 must be ≥ 0 .*included at .*/walls\.yaml:5\)"),
    (FITTED.replace("k: 120000.0", "k: stiff"), "{include: mats/hard-ice.yaml}",
     r"hard-ice\.yaml:4: materials\.0\.k: material 'hard_ice': k: .*valid number.*'stiff'"),
    (FITTED.replace("ev_b:", "ev_c:"), "{include: mats/hard-ice.yaml}",
     r"hard-ice\.yaml:8: materials\.0\.ev_c: unknown key 'ev_c'; did you mean 'ev_b'\?"),
    ("materials:\n  hard_ice: {mu: 0.25}\n", "{include: mats/hard-ice.yaml}",
     r"hard-ice\.yaml:1: materials: 'materials' is a non-empty list of materials.*older `snakesim fit-friction`"),
    ("hard_ice: {mu: 0.25}\n", "{include: mats/hard-ice.yaml}",
     r"hard-ice\.yaml: a materials file has one key, 'materials' .*got keys hard_ice"),
    ("materials:\n  - {include: other.yaml}\n", "{include: mats/hard-ice.yaml}",
     r"hard-ice\.yaml:2: materials\.0\.include: includes do not nest"),
    (FITTED.replace("hard_ice", "rock"), "{include: mats/hard-ice.yaml}", r"duplicate material name\(s\) \['rock'\]"),
])
def test_material_include_errors_name_file_key_and_value(tmp_path, fitted, entry, match):
    with pytest.raises(ConfigError, match=match):
        load_terrain(str(_terrain_with_include(tmp_path, fitted, entry)))


def test_inline_material_errors_name_the_material_and_value(tmp_path):
    f = tmp_path / "m.yaml"
    f.write_text("kind: plane\nmaterials:\n  - {name: ice}\n  - {name: granite, k: 0}\n")
    with pytest.raises(ConfigError, match=r"m\.yaml:4: materials\.1\.k: material 'granite': k = 0 N/m must be > 0"):
        load_terrain(str(f))
