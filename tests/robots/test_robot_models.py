"""Generated EELS models: topology, DOF, names, mass properties, screw pairs.

Expectations come from the EELS-DARTS paper (2.1.2-2.1.4, 2.2.4) and the
design descriptions in snakesim.robots.designs, not from running the code.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import coal
import numpy as np
import pinocchio as pin
import pytest

from snakesim.robots import DESIGNS, generate_robot

# Moving joints per module, from the design descriptions (paper 2.1.2):
# (bend, twist, screws, rear screws that mimic their front screw)
PER_MODULE = {
    "eels-concept": (1, 0, 2, 1),  # two counter-rotating screws, no twist joints
    "eels-1.0": (1, 1, 2, 1),  # "alternating": counter-rotating pair
    "eels-1.0-front": (1, 1, 1, 0),  # rear screw removed
    "eels-1.5": (1, 1, 1, 0),
    "mini-eels-1.0": (1, 0, 0, 0),  # bend joints only, no screws
}
PAIRED = [d for d, (_, _, screws, _) in PER_MODULE.items() if screws == 2]
WITH_TWIST = [d for d, (_, twist, _, _) in PER_MODULE.items() if twist]
# Designs without twist joints alternate pitch and yaw bends so they can take 3-D shapes.
ALTERNATING_BENDS = ["eels-concept", "mini-eels-1.0"]

# Plausible envelopes at the default module count (paper + hardware figures):
# EELS 1.0 is ~4 m and ~100 kg for 10 modules; EELS 1.5 is 1.5-2 m; Mini EELS
# is ~1 m and a few kg. The concept is EELS-1.0-sized per module.
MASS_RANGE_KG = {
    "eels-concept": (40.0, 130.0),
    "eels-1.0": (80.0, 120.0),
    "eels-1.0-front": (60.0, 110.0),
    "eels-1.5": (10.0, 60.0),
    "mini-eels-1.0": (1.0, 10.0),
}
LENGTH_RANGE_M = {
    "eels-concept": (2.5, 5.0),
    "eels-1.0": (3.5, 4.8),
    "eels-1.0-front": (3.5, 4.8),
    "eels-1.5": (1.5, 2.0),
    "mini-eels-1.0": (0.7, 1.3),
}


def module_counts(design: str) -> list[int]:
    return sorted({1, 4, DESIGNS[design].default_modules})


CASES = [(d, n) for d in PER_MODULE for n in module_counts(d)]


def expected_dofs(design: str, n: int, mimic_honoured: bool) -> tuple[int, int]:
    """(nq, nv) with a free-flyer root (nq 7, nv 6). Revolute joints add
    nq = nv = 1; continuous screw joints add nq = 2 (cos, sin), nv = 1; a joint
    Pinocchio turns into a mimic joint adds nothing."""
    bend, twist, screws, mimic = PER_MODULE[design]
    independent_screws = screws - (mimic if mimic_honoured else 0)
    nv = 6 + n * (bend + twist + independent_screws)
    nq = 7 + n * (bend + twist) + 2 * n * independent_screws
    return nq, nv


def joints_by_name(urdf: str) -> dict[str, ET.Element]:
    return {j.get("name"): j for j in ET.fromstring(urdf).iter("joint")}


def link_names(urdf: str) -> set[str]:
    return {link.get("name") for link in ET.fromstring(urdf).iter("link")}


def axis_of(joint: ET.Element) -> tuple[float, ...]:
    return tuple(float(v) for v in joint.find("axis").get("xyz").split())


@pytest.fixture(scope="module", params=CASES, ids=[f"{d}-{n}" for d, n in CASES])
def robot(request):
    design, n = request.param
    return generate_robot(design, modules=n)


def test_registry_has_the_paper_designs():
    assert set(DESIGNS) == set(PER_MODULE)
    assert DESIGNS["eels-1.0"].default_modules == 10  # "A robot built with 10 modules"


def test_pinocchio_dofs_follow_topology(robot):
    # Pinocchio 4.1 ignores <mimic> unless asked (mimic=False default): the
    # rear screw is then an independent DOF. With mimic=True it becomes a
    # JointModelMimic with nq = nv = 0.
    for honoured in (False, True):
        model = pin.buildModelFromXML(robot.urdf, pin.JointModelFreeFlyer(), honoured)
        assert (model.nq, model.nv) == expected_dofs(robot.design, robot.modules, honoured)
        for i in range(robot.modules):
            if model.existJointName(f"screw_rear_{i:02d}"):
                rear = model.joints[model.getJointId(f"screw_rear_{i:02d}")]
                # mimic=False: an ordinary continuous joint (unbounded revolute about x)
                assert rear.shortname() == ("JointModelMimic" if honoured else "JointModelRUBX")
    default = pin.buildModelFromXML(robot.urdf, pin.JointModelFreeFlyer())
    assert (default.nq, default.nv) == expected_dofs(robot.design, robot.modules, mimic_honoured=False)


def test_paper_dof_count_for_front_only_eels():
    # Paper 2.1.4: 10 modules with one bend, one twist and one screw each: 36 DOF.
    model = pin.buildModelFromXML(generate_robot("eels-1.0-front", modules=10).urdf, pin.JointModelFreeFlyer())
    assert model.nv == 36


@pytest.mark.parametrize("design", list(PER_MODULE))
def test_committed_file_builds_with_free_flyer(design):
    from snakesim.robots import load_robot

    path = load_robot(design).urdf_path
    assert path is not None and path.exists()
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    assert model.names[1] == "root_joint"
    assert model.frames[model.getFrameId("tail")].parentJoint == 1  # free-flyer carries the tail


def test_systematic_names(robot):
    bend, twist, screws, _ = PER_MODULE[robot.design]
    links, joints = link_names(robot.urdf), joints_by_name(robot.urdf)
    assert "tail" in links
    for i in range(robot.modules):
        assert f"module_{i:02d}" in links
        assert joints[f"bend_{i:02d}"].get("type") == "revolute"
        if twist:
            assert joints[f"twist_{i:02d}"].get("type") == "revolute"
            assert f"knuckle_{i:02d}" in links
        if screws >= 1:
            assert joints[f"screw_front_{i:02d}"].get("type") == "continuous"
        if screws == 2:
            assert joints[f"screw_rear_{i:02d}"].get("type") == "continuous"
    n_moving = sum(j.get("type") != "fixed" for j in joints.values())
    assert n_moving == robot.modules * (bend + twist + screws)
    assert f"module_{robot.modules:02d}" not in links


def test_no_floating_joint_and_tail_is_root(robot):
    joints = joints_by_name(robot.urdf)
    assert all(j.get("type") not in ("floating", "planar") for j in joints.values())
    children = {j.find("child").get("link") for j in joints.values()}
    roots = link_names(robot.urdf) - children
    assert roots == {"tail"}


def test_joint_axes(robot):
    joints = joints_by_name(robot.urdf)
    for i in range(robot.modules):
        bend = axis_of(joints[f"bend_{i:02d}"])
        if robot.design in ALTERNATING_BENDS:
            assert bend == ((0, 1, 0) if i % 2 == 0 else (0, 0, 1))
        else:
            assert bend == (0, 1, 0)
        for name in (f"twist_{i:02d}", f"screw_front_{i:02d}", f"screw_rear_{i:02d}"):
            if name in joints:
                assert axis_of(joints[name]) == (1, 0, 0)  # the robot axis


def test_joint_limits_plausible(robot):
    for joint in joints_by_name(robot.urdf).values():
        kind = joint.get("type")
        if kind == "fixed":
            continue
        limit = joint.find("limit")
        assert float(limit.get("effort")) > 0 and float(limit.get("velocity")) > 0
        if kind == "revolute":
            lower, upper = float(limit.get("lower")), float(limit.get("upper"))
            assert -math.pi <= lower < 0 < upper <= math.pi
        else:
            assert kind == "continuous" and joint.get("name").startswith("screw_")
            assert limit.get("lower") is None


def test_inertias_physically_valid(robot):
    for link in ET.fromstring(robot.urdf).iter("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        mass = float(inertial.find("mass").get("value"))
        a = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}
        tensor = np.array([[a["ixx"], a["ixy"], a["ixz"]], [a["ixy"], a["iyy"], a["iyz"]],
                           [a["ixz"], a["iyz"], a["izz"]]])
        moments = np.linalg.eigvalsh(tensor)
        assert mass > 0, link.get("name")
        assert np.all(moments > 0), link.get("name")
        for k in range(3):  # I_a <= I_b + I_c
            assert moments[k] <= moments[(k + 1) % 3] + moments[(k + 2) % 3] + 1e-12, link.get("name")


def test_massless_links_are_only_sensor_frames(robot):
    massless = {link.get("name") for link in ET.fromstring(robot.urdf).iter("link") if link.find("inertial") is None}
    joints = joints_by_name(robot.urdf)
    for name in massless:  # a massless body on a moving joint would make the mass matrix singular
        assert any(j.find("child").get("link") == name and j.get("type") == "fixed" for j in joints.values())


def _total_mass(urdf: str) -> float:
    model = pin.buildModelFromXML(urdf, pin.JointModelFreeFlyer())
    return sum(inertia.mass for inertia in model.inertias)


def _extent_along_x(urdf: str) -> tuple[float, float]:
    """Smallest and largest x reached by the collision shapes of the straight robot."""
    model = pin.buildModelFromXML(urdf, pin.JointModelFreeFlyer())
    geometry = pin.buildGeomFromUrdfString(model, urdf, pin.GeometryType.COLLISION)
    data, gdata = model.createData(), geometry.createData()
    pin.updateGeometryPlacements(model, data, geometry, gdata, pin.neutral(model))
    xs = []
    for obj, placement in zip(geometry.geometryObjects, gdata.oMg):
        shape = obj.geometry
        if isinstance(shape, coal.Cylinder):  # axis = local z
            cos = abs(placement.rotation[0, 2])
            half = cos * shape.halfLength + math.sqrt(max(0.0, 1.0 - cos**2)) * shape.radius
            xs += [placement.translation[0] - half, placement.translation[0] + half]
        elif isinstance(shape, coal.Box):
            half = np.abs(placement.rotation[0]) @ shape.halfSide
            xs += [placement.translation[0] - half, placement.translation[0] + half]
        elif isinstance(shape, coal.Sphere):
            xs += [placement.translation[0] - shape.radius, placement.translation[0] + shape.radius]
    return min(xs), max(xs)


@pytest.mark.parametrize("design", list(PER_MODULE))
def test_default_mass_and_length_plausible(design):
    robot = generate_robot(design)
    low, high = MASS_RANGE_KG[design]
    assert low <= _total_mass(robot.urdf) <= high
    x_min, x_max = _extent_along_x(robot.urdf)
    assert x_min == pytest.approx(0.0, abs=1e-9)  # the tail tip is the root frame origin
    low, high = LENGTH_RANGE_M[design]
    assert low <= x_max - x_min <= high


def test_front_only_is_eels_1_0_minus_rear_screws():
    # "The front only variant removed the rear screw for each module."
    paired, front = generate_robot("eels-1.0"), generate_robot("eels-1.0-front")
    rear_masses = [
        float(link.find("inertial/mass").get("value"))
        for link in ET.fromstring(paired.urdf).iter("link") if link.get("name").startswith("screw_rear_link_")
    ]
    assert len(rear_masses) == paired.modules
    assert _total_mass(paired.urdf) - _total_mass(front.urdf) == pytest.approx(sum(rear_masses))
    assert link_names(paired.urdf) - link_names(front.urdf) == {f"screw_rear_link_{i:02d}" for i in range(10)}


def test_mass_grows_linearly_with_modules():
    for design in PER_MODULE:
        m1, m2, m4 = (_total_mass(generate_robot(design, modules=n).urdf) for n in (1, 2, 4))
        per_module = m2 - m1
        assert per_module > 0
        # eels-1.5 adds a force-torque sensor in front of every module but the first
        assert m4 - m2 == pytest.approx(2 * per_module)


@pytest.mark.parametrize("design", PAIRED)
def test_counter_rotating_pairs(design):
    robot = generate_robot(design, modules=4)
    joints = joints_by_name(robot.urdf)
    screws = {s["joint"]: s for s in robot.metadata["screws"]}
    handedness = {"right": 1, "left": -1}
    for i in range(robot.modules):
        front, rear = joints[f"screw_front_{i:02d}"], joints[f"screw_rear_{i:02d}"]
        mimic = rear.find("mimic")
        assert mimic is not None and front.find("mimic") is None
        assert mimic.get("joint") == f"screw_front_{i:02d}"
        assert float(mimic.get("multiplier")) == -1.0 and float(mimic.get("offset")) == 0.0
        hands = screws[front.get("name")]["hand"], screws[rear.get("name")]["hand"]
        assert set(hands) == {"right", "left"}
        # A screw turning at +w about +x advances along +x when right-handed
        # (bolt in a nut), along -x when left-handed: thrust sign = hand x spin.
        spin_front, spin_rear = 1.0, float(mimic.get("multiplier"))
        assert handedness[hands[0]] * spin_front == handedness[hands[1]] * spin_rear  # thrusts add
        assert spin_front == -spin_rear  # reaction torques about the axis cancel
        # both screws of a pair sit on one rigid body (constraint embedding is exact)
        assert front.find("parent").get("link") == rear.find("parent").get("link") == f"module_{i:02d}"
        if design in WITH_TWIST:
            assert joints[f"twist_{i:02d}"].find("child").get("link") == f"module_{i:02d}"


def test_twist_joint_sits_behind_all_screws_of_a_module():
    for design in WITH_TWIST:
        joints = joints_by_name(generate_robot(design, modules=3).urdf)
        for i in range(3):
            module = joints[f"twist_{i:02d}"].find("child").get("link")
            for position in ("front", "rear"):
                screw = joints.get(f"screw_{position}_{i:02d}")
                if screw is not None:
                    assert screw.find("parent").get("link") == module


def test_metadata_matches_urdf(robot):
    joints, links = joints_by_name(robot.urdf), link_names(robot.urdf)
    meta = robot.metadata
    _, _, screws, _ = PER_MODULE[robot.design]
    assert meta["design"] == robot.design and meta["module_count"] == robot.modules
    assert len(meta["screws"]) == screws * robot.modules
    for screw in meta["screws"]:
        joint = joints[screw["joint"]]
        assert joint.find("child").get("link") == screw["link"]
        assert screw["hand"] in ("right", "left")
        assert 0 < screw["lead_angle"] < math.pi / 2
        assert 0 < screw["core_radius"] < screw["radius"] and screw["length"] > 0
        collision = ET.fromstring(robot.urdf).find(f"link[@name='{screw['link']}']/collision/geometry/cylinder")
        assert float(collision.get("radius")) == pytest.approx(screw["radius"])  # envelope = blade tips
        assert float(collision.get("length")) == pytest.approx(screw["length"])
    assert [m["index"] for m in meta["modules"]] == list(range(robot.modules))
    for module in meta["modules"]:
        assert set(module["bodies"]) <= links
        assert module["bend_joint"] in joints


def test_screw_hand_and_lead_parameters_reach_metadata():
    robot = generate_robot("eels-1.0", modules=2, hand="left", lead_angle=0.5, screw_radius=0.1)
    hands = {s["position"]: s["hand"] for s in robot.metadata["screws"]}
    assert hands == {"front": "left", "rear": "right"}
    assert {s["lead_angle"] for s in robot.metadata["screws"]} == {0.5}
    assert {s["radius"] for s in robot.metadata["screws"]} == {0.1}


def test_module_length_parameter_sets_bend_spacing():
    model = pin.buildModelFromXML(generate_robot("eels-1.0", modules=3, module_length=0.5).urdf)
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    bends = [data.oMi[model.getJointId(f"bend_{i:02d}")].translation for i in range(3)]
    assert np.linalg.norm(bends[2] - bends[1]) == pytest.approx(0.5)
    assert np.linalg.norm(bends[1] - bends[0]) == pytest.approx(0.5)


@pytest.mark.parametrize("n", [1, 2, 4, 7])
def test_eels_1_5_sensors_and_cross_bar(n):
    robot = generate_robot("eels-1.5", modules=n)
    joints, links = joints_by_name(robot.urdf), link_names(robot.urdf)
    # a force-torque sensor between consecutive modules (paper 2.2.4): a body on a
    # locked joint, and the next bend joint hangs from it so all load passes through
    fts = sorted(name for name in links if name.startswith("fts_"))
    assert len(fts) == n - 1
    for name in fts:
        i = int(name[-2:])
        joint = joints[f"fts_joint_{i:02d}"]
        assert joint.get("type") == "fixed" and joint.find("child").get("link") == name
        assert joints[f"bend_{i:02d}"].find("parent").get("link") == name
        assert ET.fromstring(robot.urdf).find(f"link[@name='{name}']/inertial") is not None
    assert {"cross_bar", "avionics_box"} <= links
    assert joints["avionics_box_joint"].find("parent").get("link") == "cross_bar"
    # the cross bar sits in the middle of the robot
    model = pin.buildModelFromXML(robot.urdf)
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    x_bar = data.oMf[model.getFrameId("avionics_box")].translation[0]
    x_min, x_max = _extent_along_x(robot.urdf)
    assert abs(x_bar - (x_min + x_max) / 2) <= (x_max - x_min) / 4


def test_perception_head_frames():
    with_head, without = generate_robot("eels-1.0", modules=3), generate_robot("eels-1.0", modules=3, head=False)
    sensors = {"imu", "lidar", "camera_left", "camera_right"}
    model = pin.buildModelFromXML(with_head.urdf, pin.JointModelFreeFlyer())
    for frame in sensors | {"head"}:
        assert model.existFrame(frame)
    joints = joints_by_name(with_head.urdf)
    for frame in sensors:
        assert joints[f"{frame}_joint"].get("type") == "fixed"
        assert joints[f"{frame}_joint"].find("parent").get("link") == "head"
    assert not (link_names(without.urdf) & (sensors | {"head"}))
    assert _total_mass(with_head.urdf) > _total_mass(without.urdf)


def test_concept_has_capped_head_and_mini_has_no_screws():
    assert "head_cap" in link_names(generate_robot("eels-concept", modules=2).urdf)
    mini = generate_robot("mini-eels-1.0")
    assert not any(name.startswith("screw") for name in joints_by_name(mini.urdf))
    assert mini.metadata["screws"] == []
