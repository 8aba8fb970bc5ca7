"""User URDFs: numbers may change, structure may not (paper 2.1.5)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pinocchio as pin
import pytest

from snakesim.robots import StructureMismatchError, URDFError, generate_robot, load_robot


def baseline_tree(design: str = "eels-1.0", **kwargs) -> ET.Element:
    return ET.fromstring(generate_robot(design, **kwargs).urdf)


def write(tmp_path: Path, root: ET.Element, name: str = "my.urdf") -> Path:
    path = tmp_path / name
    path.write_text(ET.tostring(root, encoding="unicode"))
    return path


def find(root: ET.Element, kind: str, name: str) -> ET.Element:
    return root.find(f"{kind}[@name='{name}']")


def test_numeric_changes_are_accepted(tmp_path):
    root = baseline_tree()
    for mass in root.iter("mass"):
        mass.set("value", str(1.3 * float(mass.get("value"))))
    for inertia in root.iter("inertia"):
        inertia.set("ixx", str(1.1 * float(inertia.get("ixx"))))
    for origin in root.iter("origin"):
        x, y, z = (float(v) for v in origin.get("xyz").split())
        origin.set("xyz", f"{x * 1.05} {y} {z + 0.001}")
    for limit in root.iter("limit"):
        limit.set("effort", str(2 * float(limit.get("effort"))))
    for mesh in root.iter("mesh"):
        mesh.set("filename", "package://my_robot/meshes/screw.dae")
    find(root, "joint", "bend_02").find("axis").set("xyz", "0 -1 0")  # flipped axis (the paper's example)
    mimic = find(root, "joint", "screw_rear_03").find("mimic")
    mimic.set("multiplier", "1")  # with a flipped rear axis this describes the same hardware
    find(root, "joint", "screw_rear_03").find("axis").set("xyz", "-1 0 0")
    path = write(tmp_path, root)

    robot = load_robot("eels-1.0", urdf=path)
    assert robot.source == "user" and robot.urdf_path == path.resolve()
    assert robot.urdf == path.read_text()
    assert robot.metadata["design"] == "eels-1.0" and robot.modules == 10
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    assert model.nv == 6 + 4 * 10  # still the eels-1.0 topology


def test_renamed_link_changed_type_and_moved_parent_all_listed(tmp_path):
    root = baseline_tree()
    # rename module_05 everywhere it appears (a consistent, valid URDF)
    find(root, "link", "module_05").set("name", "segment_05")
    for ref in list(root.iter("parent")) + list(root.iter("child")):
        if ref.get("link") == "module_05":
            ref.set("link", "segment_05")
    find(root, "joint", "bend_03").set("type", "prismatic")
    find(root, "joint", "twist_04").find("parent").set("link", "module_03")
    path = write(tmp_path, root)

    with pytest.raises(StructureMismatchError) as caught:
        load_robot("eels-1.0", urdf=path)
    error = caught.value
    assert isinstance(error, ValueError)
    message = str(error)
    assert message.startswith(f"{path} differs in structure from eels-1.0 (10 modules):\n")
    expected = [
        "joint 'bend_03': type 'prismatic', baseline 'revolute'",
        "joint 'twist_04': parent 'module_03', baseline 'knuckle_04'",
        "link 'segment_05': not in the baseline",
        "link 'module_05': missing (baseline has it)",
        # the rename also re-parents everything attached to the renamed body
        "joint 'twist_05': child 'segment_05', baseline 'module_05'",
        "joint 'screw_front_05': parent 'segment_05', baseline 'module_05'",
        "joint 'screw_rear_05': parent 'segment_05', baseline 'module_05'",
        "joint 'bend_06': parent 'segment_05', baseline 'module_05'",
    ]
    assert sorted(error.differences) == sorted(expected)
    for line in expected:
        assert f"\n  - {line}" in message


def test_mimic_relation_is_structural(tmp_path):
    root = baseline_tree(modules=3)
    rear = find(root, "joint", "screw_rear_01")
    rear.remove(rear.find("mimic"))
    front = find(root, "joint", "screw_front_02")
    ET.SubElement(front, "mimic", joint="screw_front_01", multiplier="1", offset="0")
    with pytest.raises(StructureMismatchError) as caught:
        load_robot("eels-1.0", modules=3, urdf=write(tmp_path, root))
    assert sorted(caught.value.differences) == [
        "joint 'screw_front_02': mimics 'screw_front_01', baseline has no mimic",
        "joint 'screw_rear_01': no mimic, baseline mimics 'screw_front_01'",
    ]


def test_module_count_and_head_are_part_of_the_baseline(tmp_path):
    path = write(tmp_path, baseline_tree(modules=4))
    assert load_robot("eels-1.0", modules=4, urdf=path).modules == 4
    with pytest.raises(StructureMismatchError) as caught:
        load_robot("eels-1.0", modules=3, urdf=path)
    assert "link 'module_03': not in the baseline" in caught.value.differences
    first, second = str(caught.value).splitlines()[:2]
    assert first.endswith("add --modules 4") and second == f"{path} differs in structure from eels-1.0 (3 modules):"
    with pytest.raises(StructureMismatchError) as caught:
        load_robot("eels-1.0", modules=4, head=False, urdf=path)
    assert "link 'imu': not in the baseline" in caught.value.differences


def test_a_different_design_is_rejected(tmp_path):
    path = write(tmp_path, baseline_tree("eels-1.0-front", modules=2))
    with pytest.raises(StructureMismatchError) as caught:
        load_robot("eels-1.0", modules=2, urdf=path)
    assert "joint 'screw_rear_00': missing (baseline has it)" in caught.value.differences


def test_malformed_xml_names_file_and_line(tmp_path):
    path = tmp_path / "broken.urdf"
    path.write_text('<?xml version="1.0"?>\n<robot name="x">\n  <link name="tail">\n</robot>\n')
    with pytest.raises(URDFError) as caught:
        load_robot("eels-1.0", urdf=path)
    assert isinstance(caught.value, ValueError)
    assert str(caught.value).startswith(f"{path}:4:")  # </robot> closes the open <link> on line 4
    assert "malformed XML" in str(caught.value)


def test_missing_file_is_named(tmp_path):
    path = tmp_path / "nowhere.urdf"
    with pytest.raises(FileNotFoundError, match="nowhere.urdf"):
        load_robot("eels-1.0", urdf=path)


@pytest.mark.parametrize(
    "text, fragment",
    [
        ('<robot name="x"/>', "no <link> elements"),
        ('<sdf version="1.6"><model name="x"/></sdf>', "root element is <sdf>"),
        ('<robot name="x"><link name="a"/><joint name="j" type="revolute"><parent link="a"/>'
         '<child link="b"/></joint></robot>', "child link 'b' is not defined"),
        ('<robot name="x"><link name="a"/><link name="a"/></robot>', "link 'a' is defined twice"),
        ('<robot name="x"><link name="a"/><link name="b"/></robot>', "exactly one root link, found 2"),
    ],
)
def test_unreadable_urdfs(tmp_path, text, fragment):
    path = tmp_path / "odd.urdf"
    path.write_text(text)
    with pytest.raises(URDFError) as caught:
        load_robot("mini-eels-1.0", urdf=path)
    assert str(caught.value).startswith(str(path))
    assert fragment in str(caught.value)


def test_a_urdf_of_another_module_count_is_named_with_the_count_to_give(tmp_path):
    """A URDF generated with 3 modules, loaded for 5: the error's first line says which --modules matches;
    a URDF that matches no count (a joint retyped) gets the differences without that line."""
    path = write(tmp_path, baseline_tree(modules=3))
    with pytest.raises(StructureMismatchError) as e:
        load_robot("eels-1.0", modules=5, urdf=path)
    assert e.value.hint is not None and str(e.value).splitlines()[0].endswith("add --modules 3")
    assert "(the scene's robot has 5)" in e.value.hint
    load_robot("eels-1.0", modules=3, urdf=path)                  # and that count loads it

    root = baseline_tree(modules=3)
    next(j for j in root.iter("joint") if j.get("type") == "revolute").set("type", "continuous")
    with pytest.raises(StructureMismatchError) as e:
        load_robot("eels-1.0", modules=5, urdf=write(tmp_path, root, "other.urdf"))
    assert e.value.hint is None and "--modules" not in str(e.value)
