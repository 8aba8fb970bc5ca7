"""Force-torque sensors of EELS 1.5 (fts_joint_01..03) in static equilibrium.

Hanging from a tether at the front, each sensor carries the part of the robot
below it (toward the tail): the tail side pulls the sensor down with its weight
m_below·g and that weight's moment about the sensor origin. Standing on its
tail, the sign flips: the tail side pushes up with the weight of the part above.
"""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from hanging import G, equilibrium, subtree
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.sensors import ForceTorqueSensors
from snakesim.framework import Harness
from snakesim.framework.registry import build_registry
from snakesim.framework.session import load_session

MODEL = RobotModel.load(design="eels-1.5")
USES = {"robot": MODEL}
SENSOR_ROWS = [MODEL.link_index(f"fts_{k:02d}") for k in (1, 2, 3)]


def _joint_wrenches(cw):
    """joint_wrenches[nl, 6] with ``cw`` in the sensor links' rows and values no sensor may read elsewhere."""
    W = np.random.default_rng(0).uniform(-1e3, 1e3, (MODEL.nl, 6))
    W[SENSOR_ROWS] = cw
    return W


def _expected(eq, support):
    out, links, mass, com = eq["out"], eq["links"], eq["mass"], eq["com"]
    rows = []
    for k in (1, 2, 3):
        above = subtree(f"fts_{k:02d}", eq["parent"])
        side = [n for n in links if (n in above) == (support == "tail")]     # the part the sensor carries
        m = sum(mass[n] for n in side)
        c = sum(mass[n] * (out["link_poses"][links.index(n), :3] + out["link_rotations"][links.index(n)] @ com[n])
                for n in side) / m
        i = links.index(f"fts_{k:02d}")
        f = m * G if support == "tether" else -m * G
        rows.append((i, m, f, np.cross(c - out["link_poses"][i, :3], f)))
    return rows


@pytest.mark.parametrize("support", ["tether", "tail"])
def test_sensors_read_the_weight_they_carry(support):
    eq = equilibrium(support)
    out = eq["out"]
    assert np.abs(out["a"]).max() < 1e-9                          # it is at rest: statics holds
    w = eq["fts"].outputs()["wrench"]
    assert eq["fts"].c.sensor_names == ["fts_joint_01", "fts_joint_02", "fts_joint_03"]
    for k, (i, m, f, tau) in enumerate(_expected(eq, support)):
        R = out["link_rotations"][i]
        scale = m * 9.81
        np.testing.assert_allclose(R @ w[k, :3], f, atol=1e-6 * scale, rtol=0)
        np.testing.assert_allclose(R @ w[k, 3:], tau, atol=1e-6 * scale * 1.0, rtol=0)
    if support == "tether":
        assert eq["tether"].outputs()["tension"][0] == pytest.approx(eq["M"] * 9.81, rel=1e-12)


def test_reading_changes_sign_between_hanging_and_standing():
    hang, stand = equilibrium("tether"), equilibrium("tail")
    for eq, sign in ((hang, 1.0), (stand, -1.0)):
        w = eq["fts"].outputs()["wrench"]
        for k, i in enumerate(eq["links"].index(f"fts_{j:02d}") for j in (1, 2, 3)):
            along_g = (eq["out"]["link_rotations"][i] @ w[k, :3]) @ G
            assert sign * along_g > 0


def test_noise_bias_and_convention():
    cw = np.arange(18.0).reshape(3, 6)
    h = Harness(ForceTorqueSensors, {"convention": "child_on_parent", "bias": {"fts_joint_02": [1, 0, 0, 0, 0, 2]}},
                uses=USES)
    h.inputs.joint_wrenches = _joint_wrenches(cw)
    expect = -cw
    expect[1] += [1, 0, 0, 0, 0, 2]
    np.testing.assert_array_equal(h.outputs()["wrench"], expect)
    n = 3000
    noisy = Harness(ForceTorqueSensors, {"force_noise": 0.5, "torque_noise": 0.02, "seed": 3}, rate=100.0,
                    uses=USES)
    noisy.inputs.joint_wrenches = _joint_wrenches(cw)
    samples = []
    for _ in range(n):
        samples.append(noisy.outputs()["wrench"] - cw)
        noisy.update()
    s = np.array(samples)
    # sample std of n normals: relative standard error 1/sqrt(2n) ~ 1.3 %; allow 5 sigma
    tol = 5 / np.sqrt(2 * n)
    assert np.allclose(s[..., :3].std(axis=0), 0.5, rtol=tol)
    assert np.allclose(s[..., 3:].std(axis=0), 0.02, rtol=tol)
    assert np.abs(s.mean(axis=0)).max() < 5 * 0.5 / np.sqrt(n)
    again = Harness(ForceTorqueSensors, {"force_noise": 0.5, "torque_noise": 0.02, "seed": 3}, rate=100.0,
                    uses=USES)
    again.inputs.joint_wrenches = _joint_wrenches(cw)
    np.testing.assert_array_equal(again.outputs()["wrench"] - cw, s[0])     # same seed, same draws
    with pytest.raises(ValueError, match="noise needs a sample rate"):
        ForceTorqueSensors("fts", {"force_noise": 0.5}, uses=USES)
    with pytest.raises(ValueError, match="bias needs 6 finite values"):
        ForceTorqueSensors("fts", {"bias": {"*": [1, 2]}}, uses=USES)


def test_cuts_by_joint_or_link_name_in_the_order_given():
    """The sensors are the cuts as named (joints, links or patterns), in that order; nothing is set on the
    multibody, which outputs every link's joint wrench."""
    cw = np.arange(18.0).reshape(3, 6)
    h = Harness(ForceTorqueSensors, {"cuts": ["fts_03", "fts_joint_01"]}, uses=USES)
    assert h.c.sensor_names == ["fts_joint_03", "fts_joint_01"]
    assert h.infos["wrench"].shape == (2, 6)
    h.inputs.joint_wrenches = _joint_wrenches(cw)
    np.testing.assert_array_equal(h.outputs()["wrench"], cw[[2, 0]])
    with pytest.raises(ValueError, match=r"fts: cuts: cut 'fts_joint_9\*' matches no joint or link .*joints: "):
        ForceTorqueSensors("fts", {"cuts": ["fts_joint_9*"]}, uses=USES)


def test_in_a_scene_the_sensors_read_the_multibodys_rows_with_no_robot_keys(tmp_path):
    """Wired as an assembly wires it: the sensors name no robot (they are handed the multibody's) and read
    exactly the sensor links' rows of its joint_wrenches (a spinning body: non-zero internal wrenches)."""
    (tmp_path / "s.yaml").write_text(textwrap.dedent("""
        sim: {duration: 0.01, dt: 0.001}
        components:
          robot: {type: multibody, params: {design: eels-1.5, base_velocity: [0, 0, 0, 2.0, 1.0, 3.0]}}
          fts: {type: force_torque_sensors}
        connections:
          - robot.joint_wrenches -> fts.joint_wrenches
        record: [fts.wrench, robot.joint_wrenches]
    """))
    session = load_session(tmp_path / "s.yaml", registry=build_registry(load_entry_points=False))
    assert session.plan.components["fts"].robot is session.plan.components["robot"].robot
    res = session.run()
    n = res["t"].size
    w = res["fts.wrench"].reshape(n, 3, 6)
    rows = res["robot.joint_wrenches"].reshape(n, MODEL.nl, 6)[:, SENSOR_ROWS]
    assert np.abs(rows).max() > 1.0
    np.testing.assert_array_equal(w, rows)
