"""DEM height fields: loaders agree, plane DEM is exact, fractal is seeded, bad input is reported."""

import numpy as np
import pytest
from surface_checks import fd_gradient, onto_surface
from PIL import Image

from snakesim.components.terrain import HeightField, build_terrain, load_terrain
from snakesim.framework import ConfigError

rng = np.random.default_rng(3)


def _grid():
    # integer heights 0..1000 so 16-bit PNG, CSV and npy hold the same values exactly
    i, j = np.mgrid[0:20, 0:30]
    return np.round(500 + 300 * np.sin(0.3 * j) * np.cos(0.2 * i) + 7 * i).astype(np.int64)


def test_npy_csv_png_give_the_same_surface(tmp_path):
    z = _grid()
    np.save(tmp_path / "g.npy", z.astype(float))
    np.savetxt(tmp_path / "g.csv", z, delimiter=",", fmt="%d")
    Image.fromarray(z.astype(np.uint16)).save(tmp_path / "g.png")
    (tmp_path / "g.meta.yaml").write_text("resolution: 0.1\norigin: [1.0, -2.0]\nz_scale: 0.001\n")
    p = np.column_stack([rng.uniform(1, 3.9, 50), rng.uniform(-2, -0.1, 50), rng.uniform(0, 1.5, 50)])
    common = {"kind": "dem", "resolution": 0.1, "origin": [1.0, -2.0], "z_scale": 0.001}
    d_npy = build_terrain({**common, "file": "g.npy"}, tmp_path).query(p)
    d_csv = build_terrain({**common, "file": "g.csv"}, tmp_path).query(p)
    d_png = build_terrain({"kind": "dem", "file": "g.png"}, tmp_path).query(p)   # all from the sidecar
    for q in (d_csv, d_png):
        np.testing.assert_allclose(q.distance, d_npy.distance, atol=1e-12)
        np.testing.assert_allclose(q.normal, d_npy.normal, atol=1e-12)
    # grid node heights come back exactly: z[i, j] at (x0 + j res, y0 + i res)
    h = build_terrain({**common, "file": "g.npy"}, tmp_path).height(np.array([1.0 + 0.1 * 7]), np.array([-2.0 + 0.1 * 4]))[0]
    assert h[0] == pytest.approx(0.001 * z[4, 7])


def test_8bit_png(tmp_path):
    z = (np.arange(12)[None, :] * 10 + np.arange(8)[:, None]).astype(np.uint8)
    Image.fromarray(z, mode="L").save(tmp_path / "a.png")
    t = build_terrain({"kind": "dem", "file": "a.png", "resolution": 0.5, "z_scale": 0.01}, tmp_path)
    assert t.height(np.array([1.0]), np.array([1.5]))[0][0] == pytest.approx(0.01 * z[3, 2])


def test_planar_dem_is_exact():
    a, b, c = 0.3, -0.2, 1.0
    y, x = np.mgrid[0:10, 0:15] * 0.2
    t = HeightField(a * x + b * y + c, 0.2)
    p = np.column_stack([rng.uniform(0, 2.8, 40), rng.uniform(0, 1.8, 40), rng.uniform(-1, 3, 40)])
    n = np.array([-a, -b, 1]) / np.sqrt(1 + a * a + b * b)
    q = t.query(p)
    np.testing.assert_allclose(q.distance, (p[:, 2] - (a * p[:, 0] + b * p[:, 1] + c)) * n[2], atol=1e-12)
    np.testing.assert_allclose(q.normal, np.tile(n, (40, 1)), atol=1e-12)


def test_dem_normal_is_gradient_on_surface():
    t = load_terrain("fractal-dem")
    p = rng.uniform(-2, 2, (60, 3))
    s = onto_surface(t, p)
    q = t.query(s)
    assert np.abs(q.distance).max() < 1e-9
    np.testing.assert_allclose(q.normal, fd_gradient(t.distance, s, eps=1e-7), atol=1e-4)


def test_fractal_is_seeded():
    spec = {"kind": "dem", "resolution": 0.05, "fractal": {"size": 64, "hurst": 0.7, "rms": 0.03, "seed": 5}}
    z1, z1b = build_terrain(spec).z, build_terrain(spec).z
    z2 = build_terrain({**spec, "fractal": {**spec["fractal"], "seed": 6}}).z
    assert np.array_equal(z1, z1b)
    assert not np.allclose(z1, z2)
    assert z1.std() == pytest.approx(0.03) and abs(z1.mean()) < 1e-12


def test_nan_dem_names_file_and_index(tmp_path):
    z = np.zeros((5, 6))
    z[2, 4] = np.nan
    np.save(tmp_path / "bad.npy", z)
    with pytest.raises(ConfigError, match=r"bad\.npy.*row 2, column 4"):
        build_terrain({"kind": "dem", "file": "bad.npy", "resolution": 0.1}, tmp_path)


def test_zero_resolution(tmp_path):
    (tmp_path / "z.yaml").write_text("kind: dem\nfractal: {size: 8}\nresolution: 0\n")
    with pytest.raises(ConfigError, match=r"z\.yaml:3: resolution: .*greater than 0"):
        load_terrain(str(tmp_path / "z.yaml"))
    np.save(tmp_path / "g.npy", np.zeros((3, 3)))
    (tmp_path / "g.meta.yaml").write_text("resolution: 0.0\n")
    with pytest.raises(ConfigError, match="resolution must be > 0"):
        build_terrain({"kind": "dem", "file": "g.npy"}, tmp_path)


def test_missing_dem_file_and_wrong_dims(tmp_path):
    with pytest.raises(ConfigError, match=r"nope\.npy: DEM file not found"):
        build_terrain({"kind": "dem", "file": "nope.npy", "resolution": 0.1}, tmp_path)
    np.save(tmp_path / "v.npy", np.zeros(7))
    with pytest.raises(ConfigError, match="must be 2-D"):
        build_terrain({"kind": "dem", "file": "v.npy", "resolution": 0.1}, tmp_path)
    np.save(tmp_path / "g.npy", np.zeros((3, 3)))
    with pytest.raises(ConfigError, match="needs 'resolution'"):
        build_terrain({"kind": "dem", "file": "g.npy"}, tmp_path)
