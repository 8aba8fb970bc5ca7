"""Robot designs are registrations (``snakesim_register_robot_designs``) and any URDF may carry a
metadata sidecar (``NAME.snakesim.yaml``): joint kinds, screws and armature, validated."""

from __future__ import annotations

import types

import pytest

from snakesim.components.contact.robot_screws import screw_layout
from snakesim.components.multibody import joint_values
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.urdf import MultibodyModelError
from snakesim.framework import hookimpl
from snakesim.framework.errors import RegistryError
from snakesim.framework.registry import Registry, make_plugin_manager
from snakesim.robots import (DESIGNS, RobotDesign, RobotMetadataError, load_robot, read_sidecar, robot_design,
                             robot_designs, sidecar_path)

URDF = """<robot name="pair">
  <link name="base"><inertial><mass value="2.0"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="arm"><inertial><mass value="1.0"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="roller"><inertial><mass value="0.5"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="elbow" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0.2 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
  <joint name="spin" type="continuous"><parent link="arm"/><child link="roller"/><origin xyz="0.1 0 0"/>
    <axis xyz="1 0 0"/><limit effort="4" velocity="10"/></joint>
</robot>
"""
SIDECAR = """joints:
  elbow: {kind: bend}
  spin: {kind: screw, armature: 0.003}
screws:
  - {joint: spin, link: roller, hand: left, lead_angle: 0.3, radius: 0.05, length: 0.1}
armature_per_effort: {bend: 0.001}
"""


def _write(tmp_path, sidecar=SIDECAR, name="pair"):
    (tmp_path / f"{name}.urdf").write_text(URDF)
    if sidecar is not None:
        (tmp_path / f"{name}.snakesim.yaml").write_text(sidecar)
    return tmp_path / f"{name}.urdf"


def test_builtin_designs_are_registered_through_the_hook():
    assert list(robot_designs()) == list(DESIGNS)
    d = robot_design("eels-1.5")
    assert d.default_modules == DESIGNS["eels-1.5"].default_modules and d.title == DESIGNS["eels-1.5"].title


def test_an_unknown_design_lists_the_registered_ones():
    with pytest.raises(KeyError, match=r"unknown robot design 'mini'\. Did you mean 'mini-eels-1.0'\?.*Valid "
                                       r"designs: eels-concept, eels-1.0, eels-1.0-front, eels-1.5, mini-eels-1.0"):
        load_robot("mini")
    with pytest.raises(MultibodyModelError, match="Valid designs: eels-concept"):
        RobotModel.load(design="eels-2.0")


def _plugin_registry(*designs, name="third_party"):
    plugin = types.SimpleNamespace()

    @hookimpl
    def snakesim_register_robot_designs(registry):
        for d in designs:
            registry.add_robot_design(d)

    plugin.snakesim_register_robot_designs = snakesim_register_robot_designs
    pm = make_plugin_manager(load_entry_points=False)
    pm.register(plugin, name=name)
    reg = Registry(pm)
    from snakesim.framework.registry import _register_each

    _register_each(pm, "snakesim_register_robot_designs", reg)
    return reg


def test_a_plugin_design_builds_from_urdf_text_and_metadata():
    import yaml

    def build(modules, scale=1.0):
        return URDF.replace('value="2.0"', f'value="{2.0 * scale}"'), yaml.safe_load(SIDECAR)

    reg = _plugin_registry(RobotDesign("test-pair", build, "two links", default_modules=1))
    assert list(robot_designs(reg))[-1] == "test-pair"
    desc = robot_design("test-pair", registry=reg).describe(scale=2.0)
    assert desc.modules == 1 and 'value="4.0"' in desc.urdf and desc.metadata["screws"][0]["hand"] == "left"
    with pytest.raises(KeyError, match="Valid designs: .*mini-eels-1.0, test-pair"):
        robot_design("test-par", registry=reg)


def test_two_plugins_registering_one_design_is_an_error_naming_both():
    reg = _plugin_registry(RobotDesign("eels-1.0", lambda modules: (URDF, {})))
    with pytest.raises(RegistryError, match="robot design 'eels-1.0' is registered by more than one plugin"):
        robot_design("eels-1.0", registry=reg)
    with pytest.raises(RegistryError, match="not a snakesim RobotDesign"):
        Registry().add_robot_design("eels-1.0")


def test_a_plugin_design_with_bad_metadata_names_the_design_and_key():
    reg = _plugin_registry(RobotDesign("test-bad", lambda modules: (URDF, {"joints": {"knee": {"kind": "bend"}}})))
    with pytest.raises(RobotMetadataError, match=r"robot design 'test-bad' metadata: joints\.knee: no moving joint "
                                                 r"'knee'.*moving joints: elbow, spin"):
        robot_design("test-bad", registry=reg).describe()


def test_a_sidecar_beside_a_bare_urdf_gives_kinds_screws_and_armature(tmp_path):
    path = _write(tmp_path)
    assert sidecar_path(path) == tmp_path / "pair.snakesim.yaml"
    robot = RobotModel.load(urdf=str(path))
    assert robot.joint_kinds == ("bend", "screw") and robot.kind_of("spin") == "screw"
    layout = robot.derived(screw_layout)
    assert layout.names == ("spin",) and list(layout.hand) == [-1] and list(layout.radius) == [0.05]
    p = types.SimpleNamespace(armature={}, armature_per_effort={}, armature_floor=0.0)
    sources = joint_values.armature_sources(robot, p)
    assert sources["spin"] == (0.003, "robot metadata: armature")
    assert sources["elbow"][0] == pytest.approx(0.001 * 10) and "armature_per_effort" in sources["elbow"][1]


def test_without_a_sidecar_kinds_come_from_names(tmp_path):
    robot = RobotModel.load(urdf=str(_write(tmp_path / "", sidecar=None, name="bare")))
    assert robot.joint_kinds == ("other", "other") and robot.metadata == {}


@pytest.mark.parametrize("edit, message", [
    (("kind: bend", "kind: elbow"), r"pair\.snakesim\.yaml: joints\.elbow\.kind = 'elbow': Input should be 'bend', "
                                    r"'twist', 'screw' or 'other'"),
    (("hand: left", "hand: sinister"), r"screws\.0\.hand = 'sinister': Input should be 'right' or 'left'"),
    (("radius: 0.05", "radius: -0.05"), r"screws\.0\.radius = -0\.05: Input should be greater than 0"),
    (("lead_angle: 0.3", "lead: 0.3"), r"unknown key 'screws\.0\.lead'; valid keys here: joint, link, hand, "
                                        r"lead_angle, radius, length"),
    (("armature_per_effort", "armature_per_efort"), r"unknown key 'armature_per_efort'; valid keys here: "
                                                    r"description, joints, screws, armature_per_effort"),
    (("link: roller", "link: arm"), r"screws\.0\.link = 'arm': joint 'spin' carries link 'roller'"),
])
def test_a_wrong_sidecar_names_file_key_value_and_what_is_valid(tmp_path, edit, message):
    path = _write(tmp_path, SIDECAR.replace(*edit))
    with pytest.raises(MultibodyModelError, match=message):
        RobotModel.load(urdf=str(path))


def test_a_json_sidecar_reads_the_same(tmp_path):
    import json

    import yaml

    (tmp_path / "pair.snakesim.json").write_text(json.dumps(yaml.safe_load(SIDECAR)))
    assert read_sidecar(tmp_path / "pair.snakesim.json")["screws"][0]["radius"] == 0.05
    (tmp_path / "bad.snakesim.json").write_text("{")
    with pytest.raises(RobotMetadataError, match=r"bad\.snakesim\.json: not valid JSON"):
        read_sidecar(tmp_path / "bad.snakesim.json")


def test_a_sidecar_beside_a_user_urdf_of_a_design_replaces_the_baseline_s_keys(tmp_path):
    from snakesim.robots.cli import write_urdf

    path, _ = write_urdf("eels-1.0-front", 2, False, tmp_path / "mine.urdf")
    base = RobotModel.load(design="eels-1.0-front", modules=2, head=False, urdf=str(path))
    assert base.derived(screw_layout).radius.tolist() == [0.09, 0.09]
    screws = [{"joint": f"screw_front_0{i}", "hand": "right", "lead_angle": 0.3, "radius": 0.1, "length": 0.15}
              for i in range(2)]
    import yaml

    (tmp_path / "mine2.urdf").write_text(path.read_text())
    (tmp_path / "mine2.snakesim.yaml").write_text(yaml.safe_dump({"screws": screws}))
    robot = RobotModel.load(design="eels-1.0-front", modules=2, head=False, urdf=str(tmp_path / "mine2.urdf"))
    assert robot.derived(screw_layout).radius.tolist() == [0.1, 0.1]
    assert robot.metadata["modules"] == base.metadata["modules"]          # the rest is the baseline's
