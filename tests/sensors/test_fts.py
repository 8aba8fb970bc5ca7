"""Force-torque sensors of EELS 1.5 (fts_joint_01..03) in static equilibrium.

Hanging from a tether at the front, each sensor carries the part of the robot
below it (toward the tail): the tail side pulls the sensor down with its weight
m_below·g and that weight's moment about the sensor origin. Standing on its
tail, the sign flips: the tail side pushes up with the weight of the part above.
"""

from __future__ import annotations

import numpy as np
import pytest

from hanging import G, equilibrium, subtree
from snakesim.components.sensors import ForceTorqueSensors
from snakesim.framework import Harness


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
    h = Harness(ForceTorqueSensors, {"design": "eels-1.5", "convention": "child_on_parent",
                                     "bias": {"fts_joint_02": [1, 0, 0, 0, 0, 2]}})
    h.inputs.cut_wrenches = cw
    expect = -cw
    expect[1] += [1, 0, 0, 0, 0, 2]
    np.testing.assert_array_equal(h.outputs()["wrench"], expect)
    n = 3000
    noisy = Harness(ForceTorqueSensors, {"design": "eels-1.5", "force_noise": 0.5, "torque_noise": 0.02, "seed": 3},
                    rate=100.0)
    noisy.inputs.cut_wrenches = cw
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
    again = Harness(ForceTorqueSensors, {"design": "eels-1.5", "force_noise": 0.5, "torque_noise": 0.02, "seed": 3},
                    rate=100.0)
    again.inputs.cut_wrenches = cw
    np.testing.assert_array_equal(again.outputs()["wrench"] - cw, s[0])     # same seed, same draws
    with pytest.raises(ValueError, match="noise needs a sample rate"):
        ForceTorqueSensors("fts", {"design": "eels-1.5", "force_noise": 0.5})
    with pytest.raises(ValueError, match="bias needs 6 finite values"):
        ForceTorqueSensors("fts", {"design": "eels-1.5", "bias": {"*": [1, 2]}})
