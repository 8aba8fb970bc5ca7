"""/tethers/attached end to end: `snakesim run tube-dangling --ros2` and a separate client (sim_client.py) that
releases the tether of the hanging robot; malformed commands are rejected and the run goes on."""

import json

import numpy as np
import pytest
from scripted_run import run_with_client

from snakesim.framework.assembly import resolve
from snakesim.framework.registry import default_registry

G = 9.81                  # m/s², the multibody's default gravity
RELEASE_AT = 0.5          # s of sim time: the robot hangs still by then (tension ≈ its weight)
DURATION = 1.2


def test_attach_wires_a_tether_source_where_the_scene_leaves_the_input_free():
    from snakesim.components.ros2.attach import attach_ros2

    reg = default_registry()
    r = resolve("tube-dangling", search_path=reg.assembly_paths(), overrides=["robot.modules=2"])
    attach_ros2(r, reg, params={"domain_id": 7})
    spec = r.components["ros2_tether_commands"]
    assert spec.params == {"domain_id": 7, "tethers": 1} and spec.rate == pytest.approx(100.0)
    assert ("ros2_tether_commands.attached", "tether.attached", "--ros2") in r.connections
    # a scene that drives the input itself keeps it: no source
    r = resolve("tube-dangling", search_path=reg.assembly_paths(), overrides=["robot.modules=2"])
    r.components["sched"] = r.components["tether"].model_copy(update={"type": "constant", "params": {"value": 1.0}})
    r.connections.append(("sched.y", "tether.attached", "test"))
    attach_ros2(r, reg)
    assert "ros2_tether_commands" not in r.components


MALFORMED = [
    ({"data": [0, 1]}, "/tethers/attached: data has 2 values for 1 tethers"),
    ({"data": [2]}, "/tethers/attached: data[0] = 2 is not 0 (release) or 1 (attach)"),
    ({"data": [0], "layout": {"dim": [{"label": "tethers", "size": 3, "stride": 3}]}},
     "/tethers/attached: layout.dim[0].size = 3 is not the tether count 1"),
]


@pytest.mark.slow
def test_releasing_the_tether_drops_the_tension_to_zero_and_the_robot_falls(dds_domain, tmp_path):
    script = [{"at": RELEASE_AT - 0.1, "topic": "/tethers/attached", "type": "UInt8MultiArray", "msg": m}
              for m, _ in MALFORMED]
    script.append({"at": RELEASE_AT, "topic": "/tethers/attached", "type": "UInt8MultiArray", "msg": {"data": [0]}})
    _, d = run_with_client(dds_domain(), tmp_path / "out", ["tube-dangling", "--set", "robot.modules=2", "--set",
                                                            "swing=0", "--duration", str(DURATION)],
                           script, client_seconds=60, timeout=120, rejections=[r for _, r in MALFORMED])
    t, tension, z = d["t"], d["tethertension0"], d["robotcomz"]
    normal = d["contactnormal_force0"]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["completed"]
    # hanging before: the tether carries the weight (it was never released by the malformed commands)
    hang = (t > RELEASE_AT - 0.15) & (t < RELEASE_AT)
    assert np.all(tension[hang] > 100.0)
    # released at a command tick just after the request; from then on the tension is exactly zero
    off = np.flatnonzero((t >= RELEASE_AT - 0.1) & (tension == 0.0))
    assert off.size, "the tension never dropped to zero"
    t_rel = t[off[0]]
    assert RELEASE_AT <= t_rel < RELEASE_AT + 0.1
    after = t >= t_rel
    np.testing.assert_array_equal(tension[after], 0.0)
    # ... and the robot falls freely (no contact in the tube's axis): its centre of mass accelerates at -g
    assert np.all(normal[after] == 0.0)
    fit = (t > t_rel + 0.02)
    acc = 2 * np.polyfit(t[fit] - t_rel, z[fit], 2)[0]
    assert acc == pytest.approx(-G, abs=0.05), acc
    assert z[-1] < z[off[0]] - 0.5 * G * (t[-1] - t_rel) ** 2 * 0.9
