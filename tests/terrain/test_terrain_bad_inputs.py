"""Issue 17: terrain definitions with non-finite numbers or geometry that cannot be built are
refused at build, naming the file, the key and the value."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.components.terrain import dem
from snakesim.components.terrain.spec import load_terrain
from snakesim.framework import ConfigError


def _refused(ref) -> str:
    with pytest.raises(ConfigError) as e:
        load_terrain(ref)
    return str(e.value)


@pytest.mark.parametrize("spec, expect", [
    (dict(kind="plane", tilt=math.nan), "tilt: Input should be a finite number (got nan)"),
    (dict(kind="plane", origin=[0, 0, math.inf]), "origin.2: Input should be a finite number (got inf)"),
    (dict(kind="tube", radius=math.inf), "radius: Input should be a finite number (got inf)"),
    (dict(kind="tube", radius=1.0, axis=[0, 0, 0]), "axis: axis = [0.0, 0.0, 0.0]: the tube's axis direction must be "
                                                     "a non-zero vector"),
    (dict(kind="tube", radius=1.0, axis=[0, math.nan, 1]), "axis.1: Input should be a finite number"),
    (dict(kind="tube", radius=0.0), "radius: Input should be greater than 0 (got 0.0)"),
    (dict(kind="parallel_walls", gap=1.0, yaw=-math.inf), "yaw: Input should be a finite number"),
    (dict(kind="moulin", radius=2.0, slope=math.nan), "slope: Input should be a finite number"),
    (dict(kind="u_channel", width=-1.0), "width: Input should be greater than 0"),
    (dict(kind="obstacles", boxes=[dict(center=[0, 0, 0], size=[0, 1, 1])]), "boxes.0.size.0: Input should be greater "
                                                                            "than 0"),
    (dict(kind="dem", fractal={"size": 8, "rms": math.inf}, resolution=0.1), "fractal.rms: Input should be a finite"),
    (dict(kind="plane", materials=[{"name": "ice", "c": math.inf}]), "material 'ice': c = inf is not a finite number"),
])
def test_non_finite_or_degenerate_geometry_is_refused(spec, expect):
    assert expect in _refused(spec)


@pytest.mark.parametrize("scale", [1e300, 1e9])
def test_dem_heights_beyond_the_bound_are_refused_naming_the_value(scale):
    msg = _refused(dict(kind="dem", fractal={"size": 8}, resolution=0.1, z_scale=scale))
    assert f"is beyond ±{dem.MAX_HEIGHT:g} m" in msg and "z_scale" in msg and "row 0, column 0" in msg


def test_dem_grid_file_with_huge_heights_is_refused(tmp_path):
    np.save(tmp_path / "g.npy", np.full((4, 4), 1e300))
    (tmp_path / "t.yaml").write_text("kind: dem\nfile: g.npy\nresolution: 0.1\n")
    msg = _refused(str(tmp_path / "t.yaml"))
    assert "DEM height 1e+300 m at row 0, column 0" in msg
    (tmp_path / "u.yaml").write_text("kind: dem\nfile: g.npy\nresolution: .inf\n")
    assert "resolution: Input should be a finite number" in _refused(str(tmp_path / "u.yaml"))


def test_a_binary_terrain_yaml_names_the_file(tmp_path):
    p = tmp_path / "t.yaml"
    p.write_bytes(b"kind: plane\n\xc3\x28")
    assert f"{p}: not UTF-8 text: byte 0xc3 at byte offset 12" in _refused(str(p))
