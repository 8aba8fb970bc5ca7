"""body_contact: single bodies on a plane, a slope and in a tube against the closed forms of the
spring-damper (eq. 2) and Coulomb (regularised) friction; skin anisotropy; agreement with the
convex-hull back end; the parameter errors.

Bodies are one-link URDFs integrated with semi-implicit Euler at dt = 1e-4 s (as the hull
tests). Stiffness is per sample: N samples in contact under a load F sink d = F / (N k).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.components.contact.body_contact import BodyContact
from snakesim.components.contact.hull import HullContact
from snakesim.components.multibody import Multibody
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.terrain import load_terrain
from snakesim.framework.harness import Harness

K, G, M = 1.0e5, 9.81, 2.0
W = M * G
CYL = '<cylinder radius="0.05" length="0.3"/>'
BOX = '<box size="0.3 0.1 0.05"/>'
ALONG_X = "0 1.5707963268 0"          # the cylinder's axis (URDF z) along the link's x


def _urdf(geometry, rpy="0 0 0"):
    return f"""<robot name="body"><link name="body">
      <inertial><mass value="{M}"/><inertia ixx="0.01" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial>
      <collision><origin xyz="0 0 0" rpy="{rpy}"/><geometry>{geometry}</geometry></collision></link></robot>"""


def _plane(mu=0.5, c=100.0, tilt=0.0):
    return load_terrain({"kind": "plane", "tilt": tilt, "materials": [{"name": "ice", "k": K, "c": c, "mu": mu}]})


def simulate(urdf, terrain, position, *, quaternion=None, velocity=(0.0,) * 6, t_end=0.3, dt=1e-4, every=10,
             back_end=BodyContact, **params):
    """Integrate one free body against ``terrain``; returns (times, poses, velocities) sampled every
    ``every`` steps, and the last contact outputs and harness."""
    mbp = {"urdf": urdf, "base_position": tuple(position), "base_velocity": tuple(velocity)}
    if quaternion is not None:
        mbp["base_quaternion"] = tuple(quaternion)
    mb = Harness(Multibody, mbp)
    bc = Harness(back_end, params, uses={"robot": mb.c.robot})
    bc.inputs.terrain = terrain
    nq, nv = mb.c._nq, mb.c._nv
    x, out = mb.x, np.empty_like(mb.x)
    ts, poses, vels = [], [], []
    for i in range(int(round(t_end / dt)) + 1):
        o = mb.outputs()
        bc.inputs.link_poses, bc.inputs.link_velocities = o["link_poses"], o["link_velocities"]
        y = bc.outputs()
        if i % every == 0:
            ts.append(i * dt)
            poses.append(o["link_poses"][0].copy())
            vels.append(o["link_velocities"][0].copy())
        mb.inputs.wrenches = y["wrenches"]
        x[nq:] += dt * mb.derivative()[nv:]
        mb.c.integrate(x, np.concatenate([dt * x[nq:], np.zeros(nv)]), out)
        x[:] = out
    return np.array(ts), np.array(poses), np.array(vels), y, bc


def _roll_x(angle):
    return (math.sin(angle / 2), 0.0, 0.0, math.cos(angle / 2))


# -- resting on a plane ------------------------------------------------------------------------

@pytest.mark.parametrize("roll_steps", [0.0, 0.5])
def test_cylinder_on_a_plane_carries_its_weight_and_sinks_F_over_Nk_plus_the_sag(roll_steps):
    """Rolled so that a line of samples is lowest (0) or two lines straddle the lowest line (half a
    step): Σ F_n = W (at rest the damper carries nothing), each contact sinks W / (N k), and the
    true cylinder's penetration e = r − z_axis exceeds that by between 0 and the sag r(1 − cos(π/n))."""
    r = 0.05
    opts = dict(spacing=0.05)
    n_around = max(8, math.ceil(2 * math.pi * r / 0.05))
    step = 2 * math.pi / n_around
    roll = roll_steps * step
    _, poses, _, y, bc = simulate(_urdf(CYL, ALONG_X), _plane(), (0, 0, r), quaternion=_roll_x(roll), **opts)
    cs = bc.outputs()["contact_set"]
    n_c = len(cs)
    rings = math.ceil(0.3 / 0.05) + 1
    assert n_c == (rings if roll_steps == 0 else 2 * rings)
    assert y["normal_force"][0] == pytest.approx(W, rel=1e-4)
    np.testing.assert_allclose(y["wrenches"][0, :3], [0, 0, W], atol=1e-4 * W)
    np.testing.assert_allclose(y["wrenches"][0, 3:], 0, atol=1e-4)            # level: no moment
    np.testing.assert_allclose(cs.depth, W / (n_c * K), rtol=1e-3)
    sag = r * (1 - math.cos(math.pi / n_around))
    e = r - poses[-1, 2]
    assert W / (n_c * K) - 1e-7 <= e <= W / (n_c * K) + sag + 1e-7
    # the two rolls are the two ends of the sampling interval: exact at each end
    assert e == pytest.approx(W / (n_c * K) + (sag if roll_steps else 0.0), abs=1e-7)


def test_resting_box_agrees_with_the_hull_back_end_at_equal_contact_counts():
    """The same cylinder on the same plane in both back ends: 3 hull slices vs 3 sample rings on the
    lowest line (spacing L/2). Both sink W / (3 k) and carry W; they share the contact law, so the
    difference is their geometry alone: 1e-3 of the sink covers the damped transient left at 0.3 s."""
    urdf = _urdf(CYL, ALONG_X)
    _, pb, _, yb, _ = simulate(urdf, _plane(c=1e3), (0, 0, 0.05), spacing=0.15)
    _, ph, _, yh, _ = simulate(urdf, _plane(c=1e3), (0, 0, 0.05), back_end=HullContact, cylinder_slices=3)
    sink_b, sink_h = 0.05 - pb[-1, 2], 0.05 - ph[-1, 2]
    assert sink_h == pytest.approx(W / (3 * K), rel=1e-3)
    assert sink_b == pytest.approx(sink_h, rel=1e-3)
    assert yb["normal_force"][0] == pytest.approx(yh["normal_force"][0], rel=1e-4)


# -- slope: sticking below the friction angle, sliding above it -----------------------------------

THETA = math.radians(20.0)
UP = np.array([math.cos(THETA), 0.0, math.sin(THETA)])         # up the slope (plane rising to +x)
NORMAL = np.array([-math.sin(THETA), 0.0, math.cos(THETA)])


def _on_slope(mu, t_end):
    q = (0.0, math.sin(-THETA / 2), 0.0, math.cos(THETA / 2))      # the box's bottom face on the slope
    return simulate(_urdf(BOX), _plane(mu=mu, tilt=THETA), 0.025 * NORMAL, quaternion=q, t_end=t_end)


def test_box_on_a_slope_above_the_friction_angle_slides_at_g_sin_minus_mu_cos():
    """a = g (sin θ − μ cos θ) down the slope. The regularisation lowers friction by the factor
    v / sqrt(v² + v_ε²) ≥ 1 − 2e-4 over the window (v ≥ 0.07 m/s): 1e-3 relative on a."""
    mu = 0.2
    t, _, v, _, _ = _on_slope(mu, 0.3)
    s = v[:, :3] @ UP
    win = t >= 0.05
    a = -np.polyfit(t[win], s[win], 1)[0]
    assert a == pytest.approx(G * (math.sin(THETA) - mu * math.cos(THETA)), rel=1e-3)


def test_box_on_a_slope_below_the_friction_angle_sticks_at_the_regularisation_creep():
    """μ = 0.5 > tan 20°: it holds, creeping at the speed where the regularised friction
    μ N v / sqrt(v² + v_ε²) equals the slope force: v = v_ε ρ / sqrt(1 − ρ²), ρ = tan θ / μ."""
    mu = 0.5
    t, _, v, _, _ = _on_slope(mu, 0.3)
    s = -(v[:, :3] @ UP)
    rho = math.tan(THETA) / mu
    creep = 1e-3 * rho / math.sqrt(1 - rho ** 2)
    assert s[t >= 0.2].mean() == pytest.approx(creep, rel=0.02)


# -- inside a tube ----------------------------------------------------------------------------

def test_cylinder_at_the_bottom_of_a_tube_balances_its_weight_on_the_lowest_line():
    """A horizontal tube of radius 0.3 m; a cylinder (r = 0.05) along its axis rests on its lowest
    sample line (neighbouring lines are 12 mm off the wall): the normals point at the tube axis
    (straight up at the bottom), Σ F_n = W, each contact sinks W / (N k)."""
    tube = load_terrain({"kind": "tube", "radius": 0.3, "axis": [1, 0, 0],
                         "materials": [{"name": "ice", "k": K, "c": 100.0, "mu": 0.3}]})
    _, poses, _, y, bc = simulate(_urdf(CYL, ALONG_X), tube, (0, 0, -0.25), spacing=0.05)
    cs = bc.outputs()["contact_set"]
    assert len(cs) == 7
    np.testing.assert_allclose(cs.normals, np.tile([0, 0, 1.0], (7, 1)), atol=1e-6)
    assert y["normal_force"][0] == pytest.approx(W, rel=1e-4)
    np.testing.assert_allclose(cs.depth, W / (7 * K), rtol=1e-3)
    assert -(0.3 - 0.05) - poses[-1, 2] == pytest.approx(W / (7 * K), rel=1e-3)   # the envelope's sink


# -- skin anisotropy ----------------------------------------------------------------------------

@pytest.mark.parametrize("direction, factor", [((1.0, 0.0), "along"), ((0.0, 1.0), "across")])
def test_box_pushed_along_or_across_its_skin_axis_decelerates_at_mu_along_or_mu_across(direction, factor):
    """A box (skin axis = its longest edge, x) thrown at 1.5 m/s along or across it: friction
    decelerates it at μ_dir g, μ_along = 0.3·0.5, μ_across = 0.3·1.5 (regularisation: < 1e-5)."""
    skin = {"along": 0.5, "across": 1.5}
    v0 = 1.5 * np.array([*direction, 0.0])
    t, _, v, _, _ = simulate(_urdf(BOX), _plane(mu=0.3), (0, 0, 0.025), velocity=(*v0, 0, 0, 0), t_end=0.25,
                             friction=skin)
    speed = v[:, :3] @ np.array([*direction, 0.0])
    win = (t >= 0.05) & (speed > 0.05)
    a = -np.polyfit(t[win], speed[win], 1)[0]
    assert a == pytest.approx(0.3 * skin[factor] * G, rel=2e-3)
    # no sideways force: the slip stays along its direction
    side = v[:, :3] @ np.array([-direction[1], direction[0], 0.0])
    assert np.abs(side).max() < 1e-6


def test_oblique_slip_friction_splits_into_mu_along_and_mu_across():
    """A cylinder sliding at 45° to its axis: F_along = −μ_along F_n s_along, F_across = −μ_across F_n s_across."""
    mb = Harness(Multibody, {"urdf": _urdf(CYL, ALONG_X), "base_position": (0, 0, 0.0499),
                             "base_velocity": (0.3, 0.3, 0, 0, 0, 0)})
    bc = Harness(BodyContact, {"friction": {"along": 0.2, "across": 2.0}}, uses={"robot": mb.c.robot})
    bc.inputs.terrain = _plane(mu=0.5)
    o = mb.outputs()
    bc.inputs.link_poses, bc.inputs.link_velocities = o["link_poses"], o["link_velocities"]
    y = bc.outputs()
    fn, f = y["normal_force"][0], y["wrenches"][0, :3]
    s = 0.3 / math.sqrt(2 * 0.3 ** 2 + 1e-6)
    assert fn > 0
    assert f[0] == pytest.approx(-0.5 * 0.2 * fn * s, rel=1e-9)
    assert f[1] == pytest.approx(-0.5 * 2.0 * fn * s, rel=1e-9)


# -- selection and errors ---------------------------------------------------------------------

def test_screw_links_are_left_to_the_screw_contact_and_every_other_link_is_sampled():
    robot = RobotModel.load(design="eels-1.0", modules=2, head=True)
    h = Harness(BodyContact, {}, uses={"robot": robot})
    sampled = {robot.links[r] for r in h.c.samples.piece_link}
    screws = {s["link"] for s in robot.metadata["screws"]}
    assert not sampled & screws
    assert "tail" in sampled and any("head" in ln for ln in sampled)
    h2 = Harness(BodyContact, {"exclude_screws": False}, uses={"robot": robot})
    assert screws <= {robot.links[r] for r in h2.c.samples.piece_link}


@pytest.mark.parametrize("params, match", [
    ({"links": ["nothing*"]}, "matches no link"),
    ({"link_friction": {"nothing*": {"along": 1, "across": 1}}}, "matches no link"),
    ({"friction": {"along": 1e-5, "across": 1.0}}, "below ev_floor"),
    ({"friction": {"along": 0.0, "across": 1.0}}, "greater than 0"),
    ({"spacing": 0.0}, "greater than 0"),
])
def test_bad_parameters_are_named(params, match):
    robot = RobotModel.load(design="mini-eels-1.0", modules=3)
    with pytest.raises(ValueError, match=match):
        Harness(BodyContact, params, uses={"robot": robot})


def test_unconnected_terrain_is_explained():
    robot = RobotModel.load(design="mini-eels-1.0", modules=3)
    h = Harness(BodyContact, {}, uses={"robot": robot})
    with pytest.raises(ValueError, match="carries no Terrain"):
        h.outputs()


def test_a_contact_deeper_than_max_depth_stops_the_run_naming_the_link():
    """A body pushed 4 cm into the ice (a bounce from a step too large for k) ends the run with a
    reason, where 2 cm under max_depth = 3 cm does not (the watch reads the deepest sample)."""
    urdf = _urdf(CYL, ALONG_X)
    for depth, stops in ((0.02, False), (0.04, True)):
        mb = Harness(Multibody, {"urdf": urdf, "base_position": (0.0, 0.0, 0.05 - depth)})
        bc = Harness(BodyContact, {"spacing": 0.05}, uses={"robot": mb.c.robot})
        bc.inputs.terrain = _plane()
        o = mb.outputs()
        bc.inputs.link_poses, bc.inputs.link_velocities = o["link_poses"], o["link_velocities"]
        bc.outputs()
        reason = bc.c._stop.reason
        assert (reason is not None) == stops, reason
        if stops:
            assert "link 'body'" in reason and "40 mm deep" in reason and "max_depth = 30 mm" in reason
