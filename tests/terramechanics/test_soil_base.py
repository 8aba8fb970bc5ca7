"""Soil laid on a base (deformable terrain ``base:``, a DEM or a plane): the virgin surface is the base's own,
and the soil law acts along the base's normal (SCM's grid over a height map), so a screw or a body pressed into
a sloped soil meets the level case's forces turned with the slope.

References: the base terrain's own query (a DEM whose samples fall on nodes is reproduced exactly: bilinear
interpolation reproduces a bilinear patch; a plane, exactly); for the forces, the independent integrations of
the level case (test_screw_thrust.py, test_body_soil.py), which a rotation of the whole problem leaves as they
are. The node lattice stays horizontal: in the slope's frame its spacing is Δ across the dip and Δ / cos α along
it, so the quadrature's border band is bounded with Δ / cos α.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from snakesim.components.terrain.dem import HeightField, fractal_heights
from snakesim.components.terrain.spec import load_terrain
from snakesim.framework import ConfigError

import test_body_soil as body
import test_screw_thrust as screw
from test_soil import SNOW

TILT, AZIMUTH = math.radians(20.0), math.radians(30.0)
ORIGIN = (0.013, -0.021, 0.35)                       # m, a point of the base plane


def soil_terrain(base, cell, soil=SNOW, origin=(-1.0, -1.0), size=(2.0, 2.0), max_tiles=64):
    return load_terrain({"kind": "deformable", "base": base, "origin": list(origin), "size": list(size),
                         "cell": cell, "max_tiles": max_tiles, "soil": soil.model_dump()})


def slope_plane(tilt=TILT):
    return {"kind": "plane", "origin": list(ORIGIN), "tilt": tilt, "azimuth": AZIMUTH}


def slope_frame(tilt=TILT):
    """(R, N): the frame whose x is world x turned into the slope plane, z its upward normal N."""
    n = np.array([-math.sin(tilt) * math.cos(AZIMUTH), -math.sin(tilt) * math.sin(AZIMUTH), math.cos(tilt)])
    a = np.array([1.0, 0.0, 0.0]) - n[0] * n
    a /= np.linalg.norm(a)
    return np.column_stack([a, np.cross(n, a), n]), n


def test_virgin_soil_on_a_dem_is_the_dem():
    """Nodes every quarter DEM sample, aligned: the soil's surface and its normal are the DEM's own, in and
    beyond the patch (the base continues there)."""
    res = 0.08
    z = fractal_heights(65, 0.8, 0.05, seed=3)
    x0 = -0.5 * 64 * res
    dem = HeightField(z, res, (x0, x0))
    t = soil_terrain({"kind": "dem", "fractal": {"size": 65, "hurst": 0.8, "rms": 0.05, "seed": 3},
                      "resolution": res}, res / 4, origin=(x0 + 4 * res, x0 + 4 * res), size=(3.2, 3.2))
    rng = np.random.default_rng(0)
    p = np.column_stack([rng.uniform(x0, -x0, 4000), rng.uniform(x0, -x0, 4000), rng.uniform(-0.2, 0.2, 4000)])
    q, ref = t.query(p), dem.query(p)
    assert np.abs(q.distance - ref.distance).max() < 1e-12
    assert np.abs(q.normal - ref.normal).max() < 1e-9
    assert t.rut_depth(p[:, 0], p[:, 1]).max() == 0.0
    assert t.bounds().hi[2] == pytest.approx(z.max()) and t.bounds().lo[2] < z.min()


def test_virgin_soil_on_a_tilted_plane_is_the_plane():
    t = soil_terrain(slope_plane(), 0.02)
    plane = load_terrain(slope_plane())
    rng = np.random.default_rng(1)
    p = np.column_stack([rng.uniform(-3, 3, 2000), rng.uniform(-3, 3, 2000), rng.uniform(-1, 1.5, 2000)])
    q, ref = t.query(p), plane.query(p)
    assert np.abs(q.distance - ref.distance).max() < 1e-9
    # the plane is sampled 1 km beyond the patch (heights ~400 m): slopes from node differences over 2 cm
    # carry ~ε·400 m / 0.02 m ≈ 4e-12 of rounding
    assert np.abs(q.normal - ref.normal).max() < 4e-11


def turned(R, pose_local, twist_local):
    """A link pose (7,) and twist (6,) given in the slope frame, in world (the frame's origin on the base)."""
    p = np.asarray(ORIGIN) + R @ pose_local[:3]
    q = (Rotation.from_matrix(R) * Rotation.from_quat(pose_local[3:])).as_quat()
    return np.concatenate([p, q]), np.concatenate([R @ twist_local[:3], R @ twist_local[3:]])


@pytest.mark.parametrize("slip", [0.05, 0.5])
def test_screw_on_a_slope_meets_the_level_cases_forces_turned(slip):
    R, n = slope_frame()
    t = soil_terrain(slope_plane(), screw.CELL, max_tiles=256)
    v_ideal = screw.OMEGA * screw.R * math.tan(screw.LEAD)
    pose, twist = turned(R, np.array([0.0, 0.0, screw.R - screw.PEN, 0.0, 0.0, 0.0, 1.0]),
                         np.array([(1.0 - slip) * v_ideal, 0.0, 0.0, 0.0, 0.0, 0.0]))
    w, per, _, _ = screw.soil_call(twist[None], poses=pose[None], terrain=t)
    ref, scale, chord = screw.reference_thrust(slip)
    border = 2.0 * (chord + screw.L) * screw.CELL / math.cos(TILT) / (chord * screw.L)
    assert w[:3] @ R[:, 0] == pytest.approx(per[screw.THRUST], rel=1e-12)      # the thrust: along the axis
    assert abs(per[screw.THRUST] - ref) <= border * scale
    assert per[screw.SINKAGE] == pytest.approx(screw.PEN, abs=(screw.CELL / math.cos(TILT)) ** 2 / screw.R)
    # and the same screw on level soil carries the same load along N as it does along ẑ there
    w_level, _, _, _ = screw.soil_call(np.array([[(1.0 - slip) * v_ideal, 0.0, 0.0, 0.0, 0.0, 0.0]]))
    assert w[:3] @ n == pytest.approx(w_level[2], rel=border)


def test_body_on_a_slope_carries_bekkers_load_along_the_normal():
    R, n = slope_frame()
    fz, fx, scale, chord = body.reference()
    t = soil_terrain(slope_plane(), body.CELL, soil=body.SAND, origin=(-0.3, -0.3), size=(0.6, 0.6), max_tiles=512)
    pose, twist = turned(R, np.array([0.0003, -0.0004, body.R - body.PEN, 0.0, 0.0, 0.0, 1.0]),
                         np.array([0.5, 0.0, 0.0, 0.0, 0.0, 0.0]))
    w, per_link = body.kernel(v=twist, pose=pose, terrain=t)
    f = w[:3]
    border = 2.0 * (chord + body.L) * body.CELL / math.cos(TILT) / (chord * body.L)
    assert abs(f @ n - fz) <= border * fz
    assert per_link[body.L_NORMAL] == pytest.approx(f @ n, rel=1e-12)        # the shear lies in the slope
    assert abs(f @ R[:, 0] - fx) <= (border + 0.5 * body.CELL / body.SAND.janosi_k) * scale
    assert abs(f @ R[:, 1]) < 1e-9 * abs(f @ R[:, 0])


@pytest.mark.parametrize("v_eps", [0.01, 1e-3])
def test_jacobian_on_a_slope_matches_finite_differences(v_eps):
    """The generalised blocks (the tangent projector, damping along N, the height derivative's N_z) against
    central differences of the kernel, as test_body_soil's level check."""
    from snakesim.components.terrain.deformable import SoilSpec

    R, n = slope_frame()
    soil = SoilSpec(**{**body.SAND.model_dump(), "janosi_k": 1e-9, "damping": 3e4})
    pose, _ = turned(R, np.array([0.0003, -0.0004, body.R - body.PEN, 0.0, 0.0, 0.0, 1.0]), np.zeros(6))
    V = np.array([0.004, -0.003, 0.001, 0.02, -0.01, 0.05])
    t = soil_terrain(slope_plane(), 0.004, soil=soil, origin=(-0.3, -0.3), size=(0.6, 0.6))
    args = dict(across=2.5, soil=soil, cell=0.004, v_eps=v_eps, terrain=t)
    w0, _, d_twist, d_pose = body.kernel(v=V, pose=pose, blocks=True, **args)
    h = 1e-8
    fd = np.empty((6, 6))
    for k in range(6):
        dv = np.zeros(6)
        dv[k] = h
        fd[:, k] = (body.kernel(v=V + dv, pose=pose, **args)[0] - body.kernel(v=V - dv, pose=pose, **args)[0]) / (2 * h)
    assert np.abs(d_twist - fd).max() <= 1e-5 * np.abs(fd).max()
    # the displacement: the sinkage along N falls as the link moves along N, whichever way it is moved
    # (∂s/∂p = −N); b follows the depth (left out of the declaration: a few % for sand's small k_c), hence 5 %.
    # Without spin: a turning link's contact points slide round it as it moves (the contact set following
    # the pose, left out), which near rest the stiff shear turns into force
    V = np.array([0.004, -0.003, 0.001, 0.0, 0.0, 0.0])
    d_pose = body.kernel(v=V, pose=pose, blocks=True, **args)[3]
    dp = 1e-9
    fdp = np.empty((3, 3))
    for k in range(3):
        up, dn = pose.copy(), pose.copy()
        up[k] += dp
        dn[k] -= dp
        fdp[:, k] = (body.kernel(v=V, pose=up, **args)[0][:3] - body.kernel(v=V, pose=dn, **args)[0][:3]) / (2 * dp)
    assert np.abs(d_pose[:3, :3] - fdp).max() <= 5e-2 * np.abs(fdp).max()
    assert np.abs(fdp[:, 0]).max() > 0.2 * np.abs(fdp[:, 2]).max()     # on the slope, x moves the depth too


def test_a_plate_on_a_slope_leaves_a_rut_along_the_normal():
    """Pressed s along N and lifted, a node keeps s − σ_B(s)/K_e along N: cos α times its vertical rut."""
    from snakesim.components.terrain.deformable_kernels import node_base, press_nodes

    t = soil_terrain(slope_plane(), 0.01)
    ii, jj = np.meshgrid(np.arange(90, 110), np.arange(90, 110), indexing="ij")
    ii, jj = ii.ravel().astype(np.int64), jj.ravel().astype(np.int64)
    s = 0.03
    ca = math.cos(TILT)
    z = np.array([node_base(t.grid, t.base_z, i, j) for i, j in zip(ii, jj)]) - s / ca
    sigma = np.zeros(ii.size)
    st = t.state
    press_nodes(t.grid, t.base_z, t.soil, st.tile_of, st.plastic, st.yield_p, st.lift, st.used, ii, jj, z, 0.2, True,
                sigma)
    bekker = (SNOW.k_c / 0.2 + SNOW.k_phi) * s ** SNOW.n
    assert np.allclose(sigma, bekker, rtol=1e-9)
    x, y = t.grid[0] + ii * t.cell, t.grid[1] + jj * t.cell
    assert np.allclose(ca * t.rut_depth(x, y), s - bekker / SNOW.elastic_k, rtol=1e-9)


def snow_file(path, lines):
    """A deformable terrain file at ``path``: ``lines`` (YAML) and the snow's soil."""
    path.write_text(lines + "soil: {include: soils/snow-us.yaml}\n")
    return str(path)


def test_a_base_that_is_not_a_height_field_is_refused_naming_the_key(tmp_path):
    path = snow_file(tmp_path / "soil-on-a-tube.yaml", "kind: deformable\nbase: {kind: tube, radius: 0.3}\n")
    with pytest.raises(ConfigError) as e:
        load_terrain(path)
    msg = str(e.value)
    assert "soil-on-a-tube.yaml" in msg and "base" in msg and "tube" in msg and "dem" in msg


def test_base_and_base_height_together_are_refused(tmp_path):
    path = snow_file(tmp_path / "both.yaml", "kind: deformable\nbase_height: 0.5\nbase: fractal-dem\n")
    with pytest.raises(ConfigError) as e:
        load_terrain(path)
    assert "both.yaml" in str(e.value) and "base_height" in str(e.value)


def test_an_unknown_base_names_the_file_and_the_terrains():
    with pytest.raises(ConfigError) as e:
        soil_terrain("fractal-demm", 0.02)
    assert "base" in str(e.value) and "fractal-dem" in str(e.value)


def test_the_rigid_wheel_refuses_a_sloped_base():
    from snakesim.components.terramechanics.wheel import RigidWheel, wheel_forces

    t = soil_terrain(slope_plane(), 0.02)
    with pytest.raises(ValueError, match="level ground"):
        wheel_forces(t, RigidWheel(0.2, 0.1), (0.0, 0.0, 0.5), 0.0, 0.2)


@pytest.mark.slow
def test_snow_on_a_dem_carries_the_robot_and_the_rut_follows_the_ground(tmp_path):
    """snow-screw-traverse on terrains/snow-dem.yaml (the shipped snow on a fractal DEM) at its own settings:
    at rest the soil carries the weight (Σ F_n along the local normals is m g within the settle's 5 % and the
    1 − cos 7.4° the steepest ground under it allows), no screw is buried, and after the drive the rutted
    surface is the DEM (an independent HeightField of the same synthesis) less the rut, nowhere flat."""
    from snakesim.framework.session import load_session

    s = load_session("snow-screw-traverse", overrides=["settle=0.8", "terrain=snow-dem"],
                     sim_overrides={"duration": 1.3})
    result = s.run(out_dir=tmp_path / "run")
    assert result.summary["outcome"] == "success"
    model = s.plan.components["robot"].dyn.model
    weight = sum(inertia.mass for inertia in model.inertias) * 9.81
    t = result["t"]
    rest = (t > 0.6) & (t < 0.8)
    fn = result["contact.normal_force"][:, 0]
    assert np.abs(fn[rest] / weight - 1.0).max() < 0.05 + (1.0 - math.cos(math.radians(7.4)))
    sink = result["contact.screw_sinkage"]
    assert np.all(sink[rest] > 0.0) and np.all(sink < 2 * 0.09)
    terrain = s.plan.caches["contact"].terrain
    from snakesim.components.terrain.deformable_files import node_coordinates

    x, y = node_coordinates(terrain)
    on = terrain.state.plastic[:terrain.tiles_used()] > 0.0
    x, y = x[on], y[on]
    dem = HeightField(-0.0013 + fractal_heights(257, 0.9, 0.06, seed=7), 0.08, (-10.24, -10.24))
    ground = dem.query(np.column_stack([x, y, np.zeros_like(x)]))
    h_dem = -ground.distance / ground.normal[:, 2]
    h = terrain.surface_height(x, y)
    rut = terrain.rut_depth(x, y)
    # nodes sample the DEM's bilinear patches at 2 cm: within its curvature's sag, (Δ²/8)·|h_xy| ≲ 1e-5 m here
    assert np.abs(h_dem - rut - h).max() < 1e-4
    assert rut.max() > 0.01 and np.ptp(h_dem) > 0.02              # a real rut, on ground that is not flat
