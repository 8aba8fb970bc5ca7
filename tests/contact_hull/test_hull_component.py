"""hull_contact: static force balance, body-to-body wrenches and filters, errors."""

import numpy as np
import pytest

from snakesim.components.contact.hull import HullContact
from snakesim.components.multibody import Multibody
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.urdf import MultibodyModelError
from snakesim.components.terrain import load_terrain
from snakesim.framework.harness import Harness

K, C, G = 1.0e5, 1.0e3, 9.81
PLANE = {"kind": "plane", "materials": [{"name": "ice", "k": K, "c": C, "mu": 0.5}]}


def _urdf(geometry, mass=2.0, rpy="0 0 0"):
    return f"""<robot name="block"><link name="block">
      <inertial><mass value="{mass}"/><inertia ixx="0.01" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial>
      <collision><origin xyz="0 0 0" rpy="{rpy}"/><geometry>{geometry}</geometry></collision></link></robot>"""


def _settle(urdf, z0, t_end=0.3, dt=1e-4, **hull):
    """Drop a free body on the plane and integrate (semi-implicit Euler) until it rests."""
    mb = Harness(Multibody, {"urdf": urdf, "base_position": (0.0, 0.0, z0)})
    hc = Harness(HullContact, hull, uses={"robot": mb.c.robot})
    hc.inputs.terrain = load_terrain(PLANE)
    nq, nv = mb.c._nq, mb.c._nv
    x, out = mb.x, np.empty_like(mb.x)
    for _ in range(int(t_end / dt)):
        o = mb.outputs()
        hc.inputs.link_poses, hc.inputs.link_velocities = o["link_poses"], o["link_velocities"]
        mb.inputs.wrenches = hc.outputs()["wrenches"]
        x[nq:] += dt * mb.derivative()[nv:]
        mb.c.integrate(x, np.concatenate([dt * x[nq:], np.zeros(nv)]), out)
        x[:] = out
    o = mb.outputs()
    hc.inputs.link_poses, hc.inputs.link_velocities = o["link_poses"], o["link_velocities"]
    return hc.outputs(), hc.u.cache.last, o


@pytest.mark.parametrize("geometry, slices, z_rest", [
    ('<box size="0.3 0.2 0.1"/>', 1, 0.05),
    ('<cylinder radius="0.05" length="0.3"/>', 3, 0.05),
])
def test_resting_body_carries_its_weight_at_the_static_deflection(geometry, slices, z_rest):
    m = 2.0
    rpy = "0 1.5707963268 0" if "cylinder" in geometry else "0 0 0"
    y, last, o = _settle(_urdf(geometry, m, rpy), z_rest + 0.002, cylinder_slices=slices)
    n = len(last["fn"])
    assert n == slices
    # force balance: Σ F_n = m g (residual: the damper's share c ż, ż → 0 at rest)
    assert y["normal_force"][0] == pytest.approx(m * G, rel=1e-3)
    np.testing.assert_allclose(y["wrenches"][0, :3], [0, 0, m * G], atol=1e-3 * m * G)
    # each piece sinks by its share of the weight: d = m g / (n k)
    np.testing.assert_allclose(last["depth"], m * G / (n * K), rtol=1e-3)
    assert o["link_poses"][0, 2] == pytest.approx(z_rest - m * G / (n * K), abs=1e-6)
    # moment balance: the contact forces act under the centre, the body stays level
    np.testing.assert_allclose(y["wrenches"][0, 3:], 0.0, atol=1e-3)
    np.testing.assert_allclose(o["link_poses"][0, 3:6], 0.0, atol=1e-5)


# -- body-to-body on eels-1.0 (4 modules), far above the ground --------------------------

ROBOT = {"design": "eels-1.0", "modules": 4}


@pytest.fixture(scope="module")
def straight():
    mb = Harness(Multibody, dict(ROBOT, base_position=(0.0, 0.0, 5.0)))
    o = mb.outputs()
    hc = Harness(HullContact, dict(body_stiffness=K), uses={"robot": mb.c.robot})
    hc.inputs.terrain = load_terrain(PLANE)
    return hc, o["link_poses"].copy(), o["link_velocities"].copy()


def _module_links(hc, i):
    return [r for r, n in enumerate(hc.c.robot.links) if n.endswith(f"_{i:02d}")]


def _press(hc, poses, vel, i, j, gap):
    """Move module j's links beside module i's (axes parallel, ``gap`` m apart in y)."""
    p = poses.copy()
    shift = poses[_module_links(hc, i)[0], :3] - poses[_module_links(hc, j)[0], :3] + [0.0, gap, 0.0]
    p[_module_links(hc, j), :3] += shift
    hc.inputs.link_poses, hc.inputs.link_velocities = p, vel
    return hc.outputs(), p


def test_non_adjacent_modules_pressed_together_get_equal_and_opposite_wrenches(straight):
    hc, poses, vel = straight
    r = 0.09                                  # screw envelope radius
    overlap = 0.01
    y, p = _press(hc, poses, vel, 0, 2, 2 * r - overlap)
    w = y["wrenches"]
    # both screws of module 0 against both of module 2, slice against slice (3 each)
    assert y["body_contacts"][0] >= 6
    assert y["body_normal_force"][0] == pytest.approx(2 * 3 * K * overlap, rel=1e-3)
    a, b = _module_links(hc, 0), _module_links(hc, 2)
    fa, fb = w[a, :3].sum(0), w[b, :3].sum(0)
    np.testing.assert_allclose(fa, -fb, atol=1e-6 * abs(fb).max())
    assert fb[1] == pytest.approx(2 * 3 * K * overlap, rel=1e-3)   # module 2 pushed to +y
    # equal, opposite and collinear: no net force and no net moment on the robot
    np.testing.assert_allclose(w[:, :3].sum(0), 0.0, atol=1e-6)
    moment = (w[:, 3:] + np.cross(p[:, :3], w[:, :3])).sum(0)
    np.testing.assert_allclose(moment, 0.0, atol=1e-6)
    assert y["normal_force"][0] == 0.0        # the ground is far below


@pytest.mark.parametrize("j", [1])
def test_adjacent_modules_are_filtered(straight, j):
    hc, poses, vel = straight
    y, _ = _press(hc, poses, vel, 0, j, 2 * 0.09 - 0.01)
    assert y["body_contacts"][0] == 0 and not y["wrenches"].any()


def test_pair_filter_skips_same_and_adjacent_modules(straight):
    hc = straight[0]
    g = hc.c.geo
    names = g.link_names

    def module(n):
        return int(n[-2:]) if n[-2:].isdigit() else (-1 if n == "tail" else 4)

    la, lb = g.piece_link[g.pair_a], g.piece_link[g.pair_b]
    gaps = [abs(module(names[a]) - module(names[b])) for a, b in zip(la, lb)]
    assert min(gaps) >= 2
    # and every piece pair two or more modules apart is there
    pieces = [module(names[l]) for l in g.piece_link]
    expected = sum(abs(pieces[i] - pieces[k]) >= 2 for i in range(len(pieces)) for k in range(i + 1, len(pieces)))
    assert len(g.pair_a) == expected


def test_screw_blades_rest_on_their_tips():
    """Blade hulls reach the envelope radius: a module lowered 1 mm into the ground touches,
    raised 1 mm above it does not."""
    mb = Harness(Multibody, {"design": "eels-1.0", "modules": 1})
    o = mb.outputs()
    hc = Harness(HullContact, {"screw_geometry": "blades", "blade_hulls": 8}, uses={"robot": mb.c.robot})
    hc.inputs.terrain = load_terrain(PLANE)
    for dz, touching in ((0.09 - 0.001, True), (0.09 + 0.001, False)):
        poses = o["link_poses"].copy()
        poses[:, 2] += dz
        hc.inputs.link_poses, hc.inputs.link_velocities = poses, o["link_velocities"]
        y = hc.outputs()
        assert (y["contacts"][0] > 0) == touching
        if touching:
            assert y["normal_force"][0] > 0
            assert np.all(hc.u.cache.last["depth"] <= 0.001 + 1e-9)


def test_spinning_screw_friction_uses_the_thread_direction():
    """One screw slice on ice, spinning: the friction force is eq. 6 with ê_v normal to the
    thread, so it has an axial part (the propulsion), unlike isotropic friction."""
    from snakesim.components.contact import contact_forces, thread_direction

    mb = Harness(Multibody, {"design": "eels-1.0-front", "modules": 1, "v0": {"screw_front_00": 10.0}})
    o = mb.outputs()
    terrain = load_terrain({"kind": "plane", "materials": [{"k": K, "c": C, "mu": 0.3, "ev_a": 3.0}]})
    hc = Harness(HullContact, {}, uses={"robot": mb.c.robot})
    hc.inputs.terrain = terrain
    poses = o["link_poses"].copy()
    poses[:, 2] += 0.09 - 0.001
    hc.inputs.link_poses, hc.inputs.link_velocities = poses, o["link_velocities"]
    hc.outputs()
    c = hc.u.cache.last
    screw = hc.c.robot.links.index("screw_front_link_00")
    on = c["link"] == screw
    assert on.sum() == 3
    axis = np.array([1.0, 0.0, 0.0])
    e = thread_direction(np.tile([0.0, 0.0, -1.0], (3, 1)), axis, 0.35, 1)
    f, _ = contact_forces(c["depth"][on], c["normal"][on], c["slip"][on], e, K, C, 0.3, 3.0, 0.0, 1e-3)
    np.testing.assert_allclose(c["force"][on], f, rtol=1e-9, atol=1e-9)
    assert abs(f[:, 0]).min() > 1.0


def test_material_table_packed_once_per_terrain_with_the_override_by_named_columns():
    """The table comes from materials.material_table (packed when a terrain object is first
    seen, not per call); the kernel gets k, c, μ, ev_a, ev_b by column name, so an override of
    μ and ev_a shows in the force exactly as the kernel computes it with those values."""
    from snakesim.components.contact import contact_forces, thread_direction
    from snakesim.components.materials import material_table

    mb = Harness(Multibody, {"design": "eels-1.0-front", "modules": 1, "v0": {"screw_front_00": 10.0}})
    o = mb.outputs()
    terrain = load_terrain({"kind": "plane", "materials": [{"k": K, "c": C, "mu": 0.3, "ev_a": 3.0, "ev_b": 0.01}]})
    hc = Harness(HullContact, {"material": {"mu": 0.2, "ev_a": 2.0}}, uses={"robot": mb.c.robot})
    hc.inputs.terrain = terrain
    poses = o["link_poses"].copy()
    poses[:, 2] += 0.09 - 0.001
    hc.inputs.link_poses, hc.inputs.link_velocities = poses, o["link_velocities"]
    hc.outputs()
    table = hc.u.cache.mats
    np.testing.assert_array_equal(table, [[K, C, 0.2, 2.0, 0.01]])
    np.testing.assert_array_equal(table, material_table(terrain.materials, hc.c.p.material, fn_max=500.0,
                                                        ev_floor=hc.c.p.ev_floor))
    hc.outputs()
    assert hc.u.cache.mats is table                              # same terrain object: not packed again
    c = hc.u.cache.last
    on = c["link"] == hc.c.robot.links.index("screw_front_link_00")
    e = thread_direction(np.tile([0.0, 0.0, -1.0], (on.sum(), 1)), np.array([1.0, 0.0, 0.0]), 0.35, 1)
    f, _ = contact_forces(c["depth"][on], c["normal"][on], c["slip"][on], e, K, C, 0.2, 2.0, 0.01, 1e-3)
    np.testing.assert_allclose(c["force"][on], f, rtol=1e-9, atol=1e-9)
    hc.inputs.terrain = load_terrain({"kind": "plane", "materials": [{"k": 2 * K, "c": C, "mu": 0.3}]})
    hc.outputs()
    np.testing.assert_array_equal(hc.u.cache.mats, [[2 * K, C, 0.2, 2.0, 0.0]])     # a new terrain: packed anew


# -- errors ---------------------------------------------------------------------------------

def test_blades_need_a_design_with_screws():
    with pytest.raises(ValueError, match="screw_geometry 'blades' needs a design with screws"):
        HullContact("c", {"screw_geometry": "blades"},
                    uses={"robot": RobotModel.load(design="mini-eels-1.0", modules=2)})


def test_unsupported_collision_geometry_is_named():
    with pytest.raises(MultibodyModelError, match="link 'block' <collision> #1: unsupported collision geometry <capsule>"):
        HullContact("c", {}, uses={"robot": RobotModel.load(urdf=_urdf('<capsule radius="0.1" length="0.2"/>'))})


def test_bad_cylinder_value_is_named():
    with pytest.raises(MultibodyModelError, match="link 'block'.*radius='-1'"):
        HullContact("c", {}, uses={"robot": RobotModel.load(urdf=_urdf('<cylinder radius="-1" length="0.2"/>'))})


def test_unconnected_terrain_is_explained():
    hc = Harness(HullContact, {}, uses={"robot": RobotModel.load(urdf=_urdf('<box size="0.1 0.1 0.1"/>'))})
    hc.inputs.link_poses = [[0, 0, 0, 0, 0, 0, 1.0]]
    with pytest.raises(ValueError, match="input 'terrain' carries no Terrain"):
        hc.outputs()
