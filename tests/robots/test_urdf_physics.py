"""Issue 17: physically impossible URDFs are refused, naming the file, the link or joint and the value."""

from __future__ import annotations

import pytest

from snakesim.components.multibody.urdf import MultibodyModelError, parse_urdf, read_urdf_text
from snakesim.robots.description import URDF_DIR

INERTIA = '<inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="{ixy}" ixz="0" iyz="0"/>'


def _urdf(mass=1.0, ixx=0.01, iyy=0.01, izz=0.01, ixy=0.0, joint_type="revolute",
          axis='<axis xyz="0 0 1"/>', limit='<limit lower="-1" upper="1" effort="10" velocity="5"/>'):
    inertial = f'<inertial><mass value="{mass}"/>{INERTIA.format(ixx=ixx, iyy=iyy, izz=izz, ixy=ixy)}</inertial>'
    return (f'<robot name="r"><link name="base">{inertial}</link><link name="arm">{inertial}</link>'
            f'<joint name="bend" type="{joint_type}"><parent link="base"/><child link="arm"/>'
            f'<origin xyz="0.1 0 0"/>{axis}{limit}</joint></robot>')


def _refused(text, source="robot.urdf") -> str:
    with pytest.raises(MultibodyModelError) as e:
        parse_urdf(text, source)
    msg = str(e.value)
    assert msg.startswith(f"{source}: ")
    return msg


def test_a_valid_urdf_parses_with_its_limits():
    tree = parse_urdf(_urdf(), "robot.urdf")
    j = tree.joint_by_name["bend"]
    assert (j.lower, j.upper, j.effort, j.velocity) == (-1.0, 1.0, 10.0, 5.0)


@pytest.mark.parametrize("kw, expect", [
    (dict(mass=0.0), "link 'base' <inertial>: mass is 0 but the inertia is not (ixx=0.01"),
    (dict(mass=2.0, ixx=0.0, iyy=0.0, izz=0.0), "mass 2 kg with a singular inertia"),
    (dict(ixx=0.01, iyy=0.01, izz=0.0), "mass 1 kg with a singular inertia"),
    (dict(ixx=0.01, iyy=0.01, izz=0.05), "breaks the triangle inequality: principal moments 0.01, 0.01, 0.05 "
                                         "need I1 + I2 >= I3"),
    (dict(ixx=0.01, iyy=0.01, ixy=0.02), "singular inertia"),                 # indefinite
    (dict(mass=-1.0), "mass -1 is negative (valid: >= 0 kg)"),
    (dict(mass="nan"), "mass value='nan' must be 1 finite numbers"),
    (dict(ixx="inf"), "ixx='inf' must be 1 finite numbers"),
])
def test_impossible_mass_properties_are_refused(kw, expect):
    msg = _refused(_urdf(**kw))
    assert expect in msg and "link 'base'" in msg


def test_a_massless_link_without_inertia_is_fine():
    parse_urdf(_urdf(mass=0.0, ixx=0.0, iyy=0.0, izz=0.0))


@pytest.mark.parametrize("joint_type", ["revolute", "continuous"])
def test_a_moving_joint_without_axis_is_refused_naming_urdf_default(joint_type):
    msg = _refused(_urdf(joint_type=joint_type, axis=""))
    assert f"joint 'bend': a {joint_type} joint without <axis xyz=...>; URDF would default to (1 0 0)" in msg
    assert "write the axis explicitly" in msg
    parse_urdf(_urdf(joint_type="fixed", axis=""))            # a fixed joint needs none


@pytest.mark.parametrize("axis, expect", [
    ('<axis xyz="0 0 0"/>', "axis xyz='0 0 0' is zero"),
    ('<axis xyz="0 nan 1"/>', "axis xyz='0 nan 1' must be 3 finite numbers"),
    ('<axis/>', "without <axis xyz=...>"),
])
def test_bad_axes_are_refused(axis, expect):
    assert expect in _refused(_urdf(axis=axis))


@pytest.mark.parametrize("limit, expect", [
    ('<limit lower="1" upper="-1" effort="1" velocity="1"/>', "limit lower=1 is above upper=-1 (need lower <= upper)"),
    ('<limit lower="-1" upper="1" effort="-3" velocity="1"/>', "limit effort=-3 is negative (valid: >= 0)"),
    ('<limit lower="-1" upper="1" effort="1" velocity="inf"/>', "limit velocity='inf' must be 1 finite numbers"),
    ('<limit lower="nan" upper="1" effort="1" velocity="1"/>', "limit lower='nan' must be 1 finite numbers"),
])
def test_bad_limits_are_refused(limit, expect):
    msg = _refused(_urdf(limit=limit))
    assert "joint 'bend'" in msg and expect in msg


def test_a_non_utf8_urdf_file_names_the_file_and_byte(tmp_path):
    p = tmp_path / "bad.urdf"
    p.write_bytes(b'<robot name="r">\xff</robot>')
    with pytest.raises(MultibodyModelError, match=r"bad\.urdf: not UTF-8 text \(invalid start byte at byte 16\)"):
        read_urdf_text(str(p))


def test_the_committed_urdfs_pass_every_check():
    paths = sorted(URDF_DIR.glob("*.urdf"))
    assert paths
    for p in paths:
        tree = parse_urdf(p.read_text(encoding="utf-8"), str(p))
        assert all(j.velocity > 0 for j in tree.dof_joints()), p
