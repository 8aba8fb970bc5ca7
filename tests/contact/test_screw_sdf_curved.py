"""Exact ring contact on curved terrain (issue 14, ring_contact="extremal"): a screw resting in a
U-channel, on a sphere-capped DEM bump and on an obstacle-field rock sinks F/k, whatever its roll and
its spin angle; a ring between two walls keeps both contacts; the flat plane's numba kernel and the
generic Terrain.query path agree.

The sink is solved for, as the robot would settle: the base height z at which the screws' total
normal force carries a load W (bisection on z), against the geometric height z₀ where the envelope
first touches. With n rings each touching one smooth surface at depth d, the model's force is n k d
(eq. 2 at rest), so the sink z₀ − z is W / (n k) up to the terrain's own query error: exact for the
analytic U-channel and the obstacles' sphere (1e-9 relative), and for the DEM the bilinear facets'
sag under the cap, res² / (8 R), plus the one-sided slope at the vertex (a tilt of res / (2 R) rad,
second order in the depth): 3 % below. The issue's requirement is 10 %.
Before (ring_contact="samples", 8 per ring): a ring rolled 22.5° rests on two samples 22.5° either
side of its lowest line and sinks r (1 − cos 22.5°) ≈ 6.9 mm more (less the channel's curvature).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.components.contact import ScrewSdfContact
from snakesim.components.multibody import Multibody
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.terrain import load_terrain
from snakesim.components.terrain.dem import HeightField
from snakesim.components.materials import Material
from snakesim.framework import Harness

ROBOT = {"design": "eels-1.0", "modules": 2, "head": False}
MODEL = RobotModel.load(**ROBOT)
K = 1.0e5
ICE = {"name": "ice", "k": K, "c": 1.0e3, "mu": 0.3, "ev_a": 3.0, "ev_b": 0.01}
R_SCREW = 0.09
ROLLS = (0.0, math.pi / 8, 0.3)                  # π/8 = 22.5°: no sample on the lowest line
SPINS = ((0.0, 0.0), (1.234, -2.5))


def robot_outputs(z, roll=0.0, spins=(0.0, 0.0), x=0.0, y=0.0):
    """Link poses etc. of the straight 2-module robot along x, axis at (x, y, z), rolled about x."""
    mb = Harness(Multibody, dict(ROBOT, base_position=(x, y, z),
                                 base_quaternion=(math.sin(roll / 2), 0.0, 0.0, math.cos(roll / 2)),
                                 q0={"screw_front_00": spins[0], "screw_front_01": spins[1]}))
    return mb.outputs()


def contact(terrain, mode="extremal", **params):
    h = Harness(ScrewSdfContact, dict(params, ring_contact=mode), name="contact", uses={"robot": MODEL})
    h.inputs.terrain = terrain
    return h


def feed(h, out):
    h.inputs.link_poses = out["link_poses"]
    h.inputs.link_velocities = out["link_velocities"]
    h.inputs.joint_v = out["joint_v"]
    return h.outputs()


def sink_under(h, load, z0, **pose):
    """z₀ − z where the total normal force is ``load`` (bisection on the base height z, 60 halvings)."""
    lo, hi = z0 - 0.03, z0 + 1e-3          # force(lo) > load (deep), force(hi) = 0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if feed(h, robot_outputs(mid, **pose))["normal_force"][0] > load:
            lo = mid
        else:
            hi = mid
    return z0 - 0.5 * (lo + hi)


def u_channel(width=0.3):
    """Channel along x, floor's lowest line at z = 0."""
    return load_terrain({"kind": "u_channel", "width": width, "origin": [0.0, 0.0, 0.5 * width],
                         "materials": [ICE]})


@pytest.mark.parametrize("spins", SPINS)
@pytest.mark.parametrize("roll", ROLLS)
def test_screws_in_a_u_channel_sink_f_over_k(roll, spins):
    """All 4 screws × 3 rings rest on the half-cylinder floor (radius 0.15 m > r): 12 contacts."""
    h = contact(u_channel())
    load = 12 * K * 1e-3                                   # F/k = 1 mm per ring
    sink = sink_under(h, load, R_SCREW, roll=roll, spins=spins)
    assert sink == pytest.approx(load / (12 * K), rel=1e-6)
    y = feed(h, robot_outputs(R_SCREW - 1e-3, roll=roll, spins=spins))
    assert y["contacts"][0] == 12


def test_before_rolled_rings_sank_up_to_r_one_minus_cos_half_the_sample_angle():
    """The sampled rings (the old model, still ring_contact="samples"): rolled 22.5°, the load is first
    carried once the surface reaches the two samples either side: several mm beyond F/k."""
    h = contact(u_channel(), mode="samples")
    load = 12 * K * 1e-3
    sink = sink_under(h, load, R_SCREW, roll=math.pi / 8)
    assert sink > 3e-3                                       # 3.36 mm measured: 3.4 F/k


def test_sink_does_not_depend_on_the_spin_angle():
    h = contact(u_channel())
    a = feed(h, robot_outputs(R_SCREW - 1e-3, roll=0.3, spins=SPINS[0]))["wrenches"].copy()
    b = feed(h, robot_outputs(R_SCREW - 1e-3, roll=0.3, spins=SPINS[1]))["wrenches"]
    assert np.abs(a).max() > 0
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-12)


def _screw_centre(screw=0):
    h = contact(load_terrain({"kind": "plane", "materials": [ICE]}))
    feed(h, robot_outputs(1.0))
    return h.u.cache.centres[screw].copy()


def dem_bump(cx, cy, radius=0.5, height=0.02, res=0.005, half=0.4):
    """Flat DEM at z = 0 with a sphere cap (radius R, ``height`` tall) centred on a grid vertex at (cx, cy)."""
    n = int(round(2 * half / res)) + 1
    g = np.linspace(-half, half, n)
    X, Y = np.meshgrid(g, g)
    cap = np.sqrt(np.maximum(radius ** 2 - X ** 2 - Y ** 2, 0.0)) - (radius - height)
    return HeightField(np.maximum(cap, 0.0), res, origin=(cx - half, cy - half),
                       materials=(Material(**ICE),), region_material=(0,))


@pytest.mark.parametrize("spins", SPINS)
@pytest.mark.parametrize("roll", ROLLS)
def test_screw_on_a_sphere_capped_dem_bump_sinks_f_over_k(roll, spins):
    """The bump (R = 0.5 m, 2 cm tall) under the middle ring of the first screw; its end rings,
    7.5 cm away along the axis, clear the cap by R − sqrt(R² − 0.075²) − d = 4.6 mm: one contact."""
    c = _screw_centre(0)
    R, res, hb = 0.5, 0.005, 0.02
    h = contact(dem_bump(c[0], c[1], R, hb, res))
    d = 1e-3
    load = K * d
    sink = sink_under(h, load, hb + R_SCREW, roll=roll, spins=spins)
    tol = 2 * (res ** 2 / (8 * R)) / d + 0.01               # facet sag (×2: either side) and the vertex tilt
    assert sink == pytest.approx(d, rel=tol)
    assert tol < 0.1
    assert feed(h, robot_outputs(hb + R_SCREW - d, roll=roll, spins=spins))["contacts"][0] == 1


@pytest.mark.parametrize("roll", ROLLS)
def test_screw_on_an_obstacle_rock_sinks_f_over_k(roll):
    """A rock (sphere R = 0.3 m) under the first screw's middle ring, its top 1 cm above the flat ground."""
    c = _screw_centre(0)
    R = 0.3
    terrain = load_terrain({"kind": "obstacles", "materials": [ICE],
                            "spheres": [{"center": [float(c[0]), float(c[1]), 0.01 - R], "radius": R}]})
    h = contact(terrain)
    d = 1e-3
    sink = sink_under(h, K * d, 0.01 + R_SCREW, roll=roll)
    assert sink == pytest.approx(d, rel=1e-6)


def test_a_ring_between_two_walls_keeps_both_contacts():
    """Walls 2(r − d) apart: each ring meets both, at depth d. The ring's extremal contact takes the
    nearer wall (exact), a sample the other (its own depth: exact here, a sample faces each wall);
    no wall is counted twice, and the lateral forces cancel."""
    d = 1e-3
    walls = load_terrain({"kind": "parallel_walls", "gap": 2 * (R_SCREW - d), "origin": [0.0, 1e-9, 0.0],
                          "materials": [ICE]})
    h = contact(walls)
    y = feed(h, robot_outputs(0.0))
    assert y["contacts"][0] == 2 * 12
    assert y["normal_force"][0] == pytest.approx(2 * 12 * K * d, rel=1e-6)
    assert abs(y["wrenches"][:, 1].sum()) < 1e-6 * y["normal_force"][0]


def test_flat_plane_numba_kernel_equals_the_generic_path():
    """The plane's numba path and Terrain.query give the same exact rings (rolled, bent, spinning)."""
    mb = Harness(Multibody, dict(ROBOT, base_position=(0.0, 0.0, 0.0895), base_velocity=(0.05, 0.01, -0.002, 0.1, 0, 0.05),
                                 q0={"twist_00": 0.3, "bend_01": 0.1}, v0={"screw_front_00": 2.0}))
    out = mb.outputs()
    plane = load_terrain({"kind": "plane", "materials": [ICE]})
    ys = []
    for fast in (True, False):
        h = contact(plane)
        h.c.fast_plane = fast
        ys.append(feed(h, out))
    assert ys[0]["contacts"][0] > 0
    np.testing.assert_allclose(ys[1]["wrenches"], ys[0]["wrenches"], rtol=0, atol=1e-12)


@pytest.mark.parametrize("roll", (0.0, math.pi / 8))
def test_pose_jacobian_matches_finite_differences_in_the_channel(roll):
    """∂wrench/∂(translation) of each screw link (port_jacobian's d_pose, as the implicit integrator reads
    it) against central differences of the wrenches, the whole robot shifted by ±1 µm along y and z,
    each ring d = 1 mm deep 2 cm off the channel's lowest line. Left out by design (jacobian_kernels.py):
    the turn of the normal, which follows the line from the channel's axis to the ring's centre, at
    1 / (R − r) per metre: 3 rings × k d / (R − r) = 5e3 N/m per screw against 3 k n_y ~ 1e5 N/m."""
    h = contact(u_channel())
    Rc, d, y0, eps = 0.15, 1e-3, 0.02, 1e-6
    z0 = Rc - math.sqrt((Rc - R_SCREW + d) ** 2 - y0 ** 2)
    feed(h, robot_outputs(z0, roll=roll, y=y0))
    assert h.outputs()["normal_force"][0] == pytest.approx(12 * K * d, rel=1e-6)
    jac = h.c.port_jacobian("wrenches", 0.0, None, h.u, h.y)
    assert jac.rows.size == 4
    left_out = 3 * K * d / (Rc - R_SCREW)
    for axis in (1, 2):
        w = []
        for sgn in (1.0, -1.0):
            dy, dz = (sgn * eps, 0.0) if axis == 1 else (0.0, sgn * eps)
            w.append(feed(h, robot_outputs(z0 + dz, roll=roll, y=y0 + dy))["wrenches"].copy())
        fd = (w[0] - w[1]) / (2 * eps)
        rows = jac.rows
        assert np.abs(fd[rows]).max() > 10 * left_out
        np.testing.assert_allclose(jac.d_pose[rows, :, axis], fd[rows], rtol=0, atol=1.1 * left_out)
