"""Physical vs ornamental (paper 2.2.3): the entity-path contract."""

from snakesim.components.viz import entities as E
from snakesim.components.viz import is_physical


def test_physical_and_debug_prefixes():
    assert is_physical(E.TERRAIN) and is_physical(E.TETHERS)
    assert is_physical(E.link_path("robot", "module_00")) and is_physical(E.link_path("robot", "tail") + "/visual")
    for debug in (E.CONTACT_POINTS, E.CONTACT_NORMAL, E.CONTACT_FRICTION, E.frame_path("tail") + "/axes"):
        assert not is_physical(debug) and debug.startswith(E.DEBUG + "/")
    assert not is_physical(E.series_path("robot.joint_q")) and not is_physical(E.REAL_TIME_FACTOR)
    # a prefix match is on whole path parts: 'world/physicalish' is not physical
    assert not is_physical("world/physicalish/thing") and is_physical("/world/physical/x")


def test_names_become_entity_parts():
    assert E.series_path("robot.joint_q") == "plots/robot/joint_q"
    assert E.series_path("module/3/pid.tau") == "plots/module/3/pid/tau"     # included components nest
    assert E.link_path("robot", "a link.1") == "world/physical/robot/a_link_1"
