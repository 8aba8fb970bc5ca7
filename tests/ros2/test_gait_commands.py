"""/gait/parameters end to end: `snakesim run mini-eels-crawl --ros2` and a separate client process
(gait_client.py, cyclonedds on loopback) that changes the serpenoid gait's frequency mid-run: the measured
yaw joint's oscillation changes from the scene's frequency to the commanded one; malformed commands are
rejected, naming the field, and the run goes on."""

import math

import numpy as np
import pytest
from scripted_run import parameter, run_with_client

from snakesim.components.ros2.gait_commands import Ros2GaitCommands
from snakesim.components.ros2.messages import ros_type
from snakesim.components.ros2.rejections import Rejected

F0, F1 = 1.0, 2.0          # Hz: the scene's frequency, then the commanded one
CHANGE_AT = 2.0            # s of sim time
DURATION = 4.0

MALFORMED = [
    ({"changed_parameters": [{"name": "speed", "value": {"type": 3, "double_value": 1.0}}]},
     "/gait/parameters: changed_parameters[0].name = 'speed' is not a parameter here"),
    ({"changed_parameters": [{"name": "frequency", "value": {"type": 3, "double_value": -1.0}}]},
     "/gait/parameters: changed_parameters[0].value (frequency) = -1 Hz is out of range (>= 0)"),
    ({"changed_parameters": [{"name": "frequency", "value": {"type": 4, "string_value": "fast"}}]},
     "/gait/parameters: changed_parameters[0].value.type = 4 for 'frequency' is not a number"),
    ({"changed_parameters": [{"name": "direction", "value": {"type": 2, "integer_value": 0}}]},
     "/gait/parameters: changed_parameters[0].value (direction) = 0 is not +1 or -1"),
]


def test_validate_names_the_field():
    E = ros_type("rcl_interfaces/msg/ParameterEvent")
    ok = Ros2GaitCommands.validate(E(changed_parameters=[parameter("frequency", 0.8), parameter("direction", -1, 2)]))
    assert ok == {"frequency": 0.8, "direction": -1.0}
    with pytest.raises(Rejected, match=r"changed_parameters\[1\].name = 'frequency' is given twice"):
        Ros2GaitCommands.validate(E(changed_parameters=[parameter("frequency", 0.8), parameter("frequency", 0.9)]))
    with pytest.raises(Rejected, match=r"value \(frequency\) = nan is not finite"):
        Ros2GaitCommands.validate(E(changed_parameters=[parameter("frequency", math.nan)]))
    with pytest.raises(Rejected, match=r"value \(wavelength\) = 0 joints is out of range \(> 0\)"):
        Ros2GaitCommands.validate(E(changed_parameters=[parameter("wavelength", 0.0)]))
    with pytest.raises(Rejected, match="all empty"):
        Ros2GaitCommands.validate(E())
    # deleting a parameter gives it back to the scene (NaN)
    back = Ros2GaitCommands.validate(E(deleted_parameters=[parameter("frequency", 0.0)]))
    assert list(back) == ["frequency"] and math.isnan(back["frequency"])


def dominant_frequency(t, q):
    """Hz: the frequency whose sine and cosine, with an offset and a drift, fit q best (least squares over a
    fine grid: the residual is smallest there)."""
    grid = np.arange(0.2, 4.0, 0.005)
    res = []
    for f in grid:
        M = np.c_[np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t), np.ones_like(t), t - t.mean()]
        c = np.linalg.lstsq(M, q, rcond=None)[0]
        res.append(float(np.sum((M @ c - q) ** 2)))
    return float(grid[int(np.argmin(res))])


@pytest.mark.slow
def test_frequency_command_changes_the_joint_motion(dds_domain, tmp_path):
    topic, typ = "/gait/parameters", "ParameterEvent"
    script = [{"at": CHANGE_AT - 0.3, "topic": topic, "type": typ, "msg": m} for m, _ in MALFORMED]
    script.append({"at": CHANGE_AT, "topic": topic, "type": typ,
                   "msg": {"changed_parameters": [{"name": "frequency", "value": {"type": 3, "double_value": F1}}]}})
    _, d = run_with_client(dds_domain(), tmp_path / "out", ["mini-eels-crawl", "--set", "robot.modules=3", "--set",
                                                            f"frequency={F0}", "--duration", str(DURATION)],
                           script, client="gait_client.py", timeout=180, rejections=[r for _, r in MALFORMED])
    t, q = d["t"], d["robotjoint_qbend_01"]
    before = (t > 0.2) & (t < CHANGE_AT - 0.05)        # 1.75 cycles at F0 (the malformed commands change nothing)
    after = t > CHANGE_AT + 0.5                          # the PD's transient over
    # the grid's resolution over these windows: the fit's peak is 1/T wide, its centre far sharper
    assert dominant_frequency(t[before], q[before]) == pytest.approx(F0, rel=0.1)
    assert dominant_frequency(t[after], q[after]) == pytest.approx(F1, rel=0.05)


def test_attach_wires_the_gait_inputs_the_scene_leaves_free():
    from snakesim.components.ros2.attach import attach_ros2
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry

    reg = default_registry()
    r = resolve("mini-eels-pipe-climb", search_path=reg.assembly_paths())
    r.connections.append(("gravity.y", "gait.amplitude", "test"))        # a scene that drives one input itself
    attach_ros2(r, reg, params={"domain_id": 7})
    spec = r.components["ros2_gait_commands"]
    assert spec.params == {"domain_id": 7} and spec.rate == pytest.approx(100.0)
    wired = sorted(d for s, d, _ in r.connections if s.startswith("ros2_gait_commands."))
    assert wired == ["gait.direction", "gait.frequency", "gait.phase_step"]
    # a scene without a shape gait gets no source
    r = resolve("tube-dangling", search_path=reg.assembly_paths(), overrides=["robot.modules=2"])
    attach_ros2(r, reg)
    assert "ros2_gait_commands" not in r.components
