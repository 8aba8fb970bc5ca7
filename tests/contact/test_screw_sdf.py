"""screw_sdf_contact alone (harness): samples independent of the spin angle, the spin from
joint_v equals the screw link's own motion (rear screw of a pair at −rate), broad phase,
wrenches = the ContactSet's forces, and the errors."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.contact import ScrewSdfContact, body_wrenches
from snakesim.components.contact.robot_screws import RobotScrewError
from snakesim.components.multibody import Multibody
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.terrain import load_terrain
from snakesim.framework import Harness

ROBOT = {"design": "eels-1.0", "modules": 2, "head": False}
MODEL = RobotModel.load(**ROBOT)
ICE = {"kind": "plane", "materials": [{"name": "ice", "k": 1.0e5, "c": 1.0e3, "mu": 0.3, "ev_a": 3.0, "ev_b": 0.01}]}


def robot_state(z=0.0895, screw_angles=(0.3, -1.1), screw_rates=(2.0, -3.0), roll=0.05, bend=0.1):
    """Link poses/velocities/joint rates of a 2-module eels-1.0 lying (almost) on z = 0."""
    mb = Harness(Multibody, dict(ROBOT, base_position=(0.0, 0.0, z), base_velocity=(0.05, 0.01, -0.002, 0.1, 0.0, 0.05),
                                 q0={"screw_front_00": screw_angles[0], "screw_front_01": screw_angles[1],
                                     "twist_00": roll, "bend_01": bend},
                                 v0={"screw_front_00": screw_rates[0], "screw_front_01": screw_rates[1]}))
    out = mb.outputs()
    return mb, out


def contact(**params):
    h = Harness(ScrewSdfContact, params, name="contact", uses={"robot": MODEL})
    h.inputs.terrain = load_terrain(ICE)
    return h


def feed(h, out):
    h.inputs.link_poses = out["link_poses"]
    h.inputs.link_velocities = out["link_velocities"]
    h.inputs.joint_v = out["joint_v"]
    return h.outputs()


def test_forces_do_not_depend_on_the_spin_angle():
    h = contact()
    _, a = robot_state(screw_angles=(0.0, 0.0))
    _, b = robot_state(screw_angles=(1.234, -2.5))
    rows = [h.c.robot.link_index(n) for n in ("screw_front_link_00", "screw_front_link_01")]
    assert not np.allclose(a["link_poses"][rows, 3:], b["link_poses"][rows, 3:])   # the screws did turn
    ya, yb = feed(h, a), feed(h, b)
    assert ya["contacts"][0] > 0
    np.testing.assert_allclose(yb["wrenches"], ya["wrenches"], rtol=0, atol=1e-12)


def test_slip_is_the_screw_links_own_material_velocity():
    """v at p_c from the parent body + spin_mult·joint_v equals v_S + ω_S × (p_c − o_S) from the
    multibody's screw-link velocities: the rear screw of each pair turns at −rate."""
    h = contact()
    mb, out = robot_state()
    feed(h, out)
    cs = h.outputs()["contact_set"]
    assert len(cs) >= 4 and set(cs.link) >= {mb.c.link_index("screw_rear_link_00"), mb.c.link_index("screw_front_link_00")}
    o = out["link_poses"][cs.link, :3]
    v = out["link_velocities"][cs.link]
    expected = v[:, :3] + np.cross(v[:, 3:], cs.points - o)
    np.testing.assert_allclose(cs.slip, expected, rtol=0, atol=1e-12)


def test_wrenches_are_the_contact_forces_about_each_screw_link_origin():
    h = contact()
    _, out = robot_state()
    y = feed(h, out)
    cs = y["contact_set"]
    ref = body_wrenches(cs.points, cs.forces, out["link_poses"][:, :3], cs.link)
    np.testing.assert_allclose(y["wrenches"], ref, rtol=0, atol=1e-10)
    assert y["normal_force"][0] == pytest.approx(cs.normal_force.sum(), rel=1e-12)
    assert y["contacts"][0] == len(cs)
    # never pulling: every contact pushes out of the ice
    assert np.all(cs.normal_force >= 0) and np.all((cs.forces * cs.normals).sum(axis=1) >= 0)


def test_normal_force_is_the_penalty_spring_at_rest():
    """Robot at rest, level, axis at z = r − d: each ring's bottom sample (φ = 3π/2 with 8 per ring)
    is in contact at depth d: F_n = k d per sample (eq. 2, ḋ = 0), rings × screws samples."""
    mb = Harness(Multibody, dict(ROBOT, base_position=(0.0, 0.0, 0.09 - 1e-4)))
    out = mb.outputs()
    h = contact(rings=3, per_ring=8)
    y = feed(h, out)
    n = 3 * h.c.screws.ns
    assert y["contacts"][0] == n
    assert y["normal_force"][0] == pytest.approx(n * 1.0e5 * 1e-4, rel=1e-9)


def test_broad_phase_skips_a_robot_far_from_the_ground_and_changes_nothing_in_contact():
    far = contact()
    _, high = robot_state(z=2.0)
    y = feed(far, high)
    assert far.u.cache.stats["screws_tested"] == 0 and far.u.cache.stats["samples_queried"] == 0
    assert not y["wrenches"].any() and y["contacts"][0] == 0
    # in contact: the same wrenches with and without the broad phase (planes in numba and
    # through Terrain.query alike), and the broad phase sends fewer screws on when pitched up
    _, low = robot_state()
    results = []
    for broad in (True, False):
        for fast in (True, False):
            h = contact(broad_phase=broad)
            h.c.fast_plane = fast
            results.append((h, feed(h, low)["wrenches"]))
    for h, w in results[1:]:
        np.testing.assert_allclose(w, results[0][1], rtol=0, atol=1e-12)
    # tail end on the ice, nose up 10°: only the first screws reach it
    mb = Harness(Multibody, dict(ROBOT, base_position=(0.0, 0.0, 0.0), base_quaternion=(0, -0.0872, 0, 0.9962)))
    tilted = mb.outputs()
    on, off = contact(broad_phase=True), contact(broad_phase=False)
    y_on, y_off = feed(on, tilted), feed(off, tilted)
    assert y_on["contacts"][0] > 0
    np.testing.assert_allclose(y_on["wrenches"], y_off["wrenches"], rtol=0, atol=1e-12)
    assert 0 < on.u.cache.stats["screws_tested"] < off.u.cache.stats["screws_tested"] == on.c.screws.ns


def test_material_override_replaces_the_terrain_value():
    _, out = robot_state()
    base, iso = contact(), contact(material={"ev_a": 1.0, "ev_b": 0.0})
    fb, fi = feed(base, out)["contact_set"], feed(iso, out)["contact_set"]
    np.testing.assert_allclose(fi.normal_force, fb.normal_force, rtol=1e-12)
    # isotropic: friction exactly opposes the slip's tangential part
    vt = fi.slip - (fi.slip * fi.normals).sum(1)[:, None] * fi.normals
    ft = fi.forces - fi.normal_force[:, None] * fi.normals
    np.testing.assert_allclose(np.cross(ft, vt), 0.0, atol=1e-9)
    assert not np.allclose(fb.forces, fi.forces)


def test_a_bare_urdf_is_refused_with_what_to_give():
    with pytest.raises(RobotScrewError, match="give 'design'"):
        Harness(ScrewSdfContact, {}, uses={"robot": RobotModel.load(urdf="<robot name='x'><link name='a'/></robot>")})


def test_a_design_without_screws_is_refused():
    with pytest.raises(RobotScrewError, match="has no screws"):
        Harness(ScrewSdfContact, {}, uses={"robot": RobotModel.load(design="mini-eels-1.0", modules=2)})


def test_an_unconnected_terrain_is_named():
    h = Harness(ScrewSdfContact, {}, name="contact", uses={"robot": MODEL})
    _, out = robot_state()
    with pytest.raises(ValueError, match="contact: input 'terrain'"):
        feed(h, out)


def test_bad_sampling_parameters_are_rejected():
    with pytest.raises(ValueError, match="per_ring"):
        Harness(ScrewSdfContact, dict(per_ring=0), uses={"robot": MODEL})


def test_the_contact_set_describes_its_inputs_even_when_output_ran_at_others():
    """calc_contact_set reuses the last evaluation only if it saw these very inputs and terrain; else it
    evaluates again into scratch outputs (the held outputs stay as output() left them)."""
    _, a = robot_state(z=0.0895)
    _, b = robot_state(z=0.0890)                       # deeper: other forces
    h = contact()
    ya = feed(h, a)
    ref_b = feed(contact(), b)["contact_set"]
    for name in ("link_poses", "link_velocities", "joint_v"):
        h.set_input(name, b[name])
    h.c.calc_contact_set(0.0, None, h.u, h.y)          # output() has not run at b
    cs = h.y.contact_set
    np.testing.assert_array_equal(cs.normal_force, ref_b.normal_force)
    np.testing.assert_array_equal(cs.points, ref_b.points)
    np.testing.assert_array_equal(h.y.wrenches, ya["wrenches"])        # outputs untouched
    # a new terrain object (softer ice) at the same inputs: evaluated again too
    soft = dict(ICE, materials=[dict(ICE["materials"][0], k=5.0e4)])
    h.inputs.terrain = load_terrain(soft)
    h.c.calc_contact_set(0.0, None, h.u, h.y)
    np.testing.assert_allclose(h.y.contact_set.normal_force, 0.5 * ref_b.normal_force, rtol=0.05)


def test_a_contact_deeper_than_max_depth_stops_the_run_naming_the_screw():
    """Screws 4 cm into the ice (a bounce from a step too large for k) end the run with a reason, where
    2 cm under max_depth = 3 cm does not."""
    for depth, stops in ((0.02, False), (0.04, True)):
        mb = Harness(Multibody, dict(ROBOT, base_position=(0.0, 0.0, 0.09 - depth)))
        h = contact()
        feed(h, mb.outputs())
        reason = h.c._stop.reason
        assert (reason is not None) == stops, reason
        if stops:
            assert "screw link 'screw_" in reason and "40 mm deep" in reason and "max_depth = 30 mm" in reason
