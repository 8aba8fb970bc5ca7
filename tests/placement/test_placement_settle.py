"""Settling: attraction law and time-limit error on the component alone; whole scenes settle within 1 mm."""

import numpy as np
import pytest

from snakesim.components.multibody import Multibody
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.placement import Settle, SettlePhase
from snakesim.components.terrain.spec import load_terrain
from snakesim.framework.harness import Harness
from snakesim.framework.session import load_session

ROBOT = dict(design="eels-1.5", modules=4)
USES = {"robot": RobotModel.load(**ROBOT)}


def straight_poses(z):
    h = Harness(Multibody, dict(ROBOT, base_position=[0.0, 0.0, z]))
    return h.outputs()


def settle(**params):
    h = Harness(Settle, params, rate=1000.0, uses=USES)
    h.inputs.terrain = load_terrain("flat-ice")
    return h


def feed(h, o):
    """A multibody's outputs o (link poses, velocities, joint angles) into the settle harness h."""
    h.inputs.link_poses, h.inputs.link_velocities, h.inputs.joint_q = o["link_poses"], o["link_velocities"], o["joint_q"]


def test_attraction_is_k_times_distance_along_minus_normal_and_drag_opposes_motion():
    # straight robot, screw envelopes (r = 0.07) at height z: every screw's nearest sample is z − 0.07 above
    # the ice; the pull on it is k (z − 0.07) straight down, nothing else (at rest: no drag)
    z, k = 0.12, 3000.0
    o = straight_poses(z)
    h = settle(k_attract=k)
    feed(h, o)
    y = h.outputs()
    np.testing.assert_allclose(y["gap"], z - 0.07, atol=1e-12)
    W = y["wrenches"]
    np.testing.assert_allclose(W[:, 2].sum(), -4 * k * (z - 0.07), rtol=1e-12)
    np.testing.assert_allclose(W[:, :2], 0.0, atol=1e-9)
    assert y["gravity"][0] == 0.0 and y["phase"][0] == SettlePhase.SETTLING
    assert np.isnan(y["settle_time"][0])
    # a link moving at v feels −ζ m v
    v = o["link_velocities"].copy()
    v[:, 0] = 0.1
    h.inputs.link_velocities = v
    W2 = h.outputs()["wrenches"]
    assert W2[:, 0].sum() == pytest.approx(-8.0 * 0.1 * h.c._mass.sum(), rel=1e-12)


def test_not_settled_by_time_limit_stops_the_run_with_the_reason():
    o = straight_poses(0.5)
    h = settle(time_limit=1.0)
    feed(h, o)
    h.update(0.5)
    assert h.c._stop.reason is None
    h.update(1.0)
    assert "did not settle within time_limit 1 s" in h.c._stop.reason and "0/4 screws" in h.c._stop.reason


def test_rate_is_required():
    with pytest.raises(ValueError, match="give it a rate"):
        Settle("s", {}, uses=USES)


def test_latch_after_quiet_time_sets_gravity_setpoints_and_preload():
    # screws resting on the ice at rest: in contact and still -> latch after quiet_time
    o = straight_poses(0.0695)
    h = settle(quiet_time=0.01, preload=50.0)
    feed(h, o)
    for i in range(12):
        h.update(i * 1e-3)
    y = h.outputs(0.012)
    # load_time 0: straight to holding (phase 2), gravity on at the latch
    assert y["phase"][0] == SettlePhase.HOLDING and y["gravity"][0] == 1.0
    assert y["settle_time"][0] == pytest.approx(0.01)
    assert y["hold_time"][0] == pytest.approx(0.01)
    assert np.all(y["wrenches"] == 0.0)
    # on one plane the pressing forces cannot balance (all push down): the self-equilibrated preload is ~0
    assert np.abs(h.u.cache.preload_forces).max() < 1e-3 * 50.0


def test_loading_phase_keeps_gravity_off_and_joints_free_then_latches_the_loaded_shape():
    o = straight_poses(0.0695)
    h = settle(quiet_time=0.01, load_time=0.005)
    feed(h, o)
    for i in range(12):
        h.update(i * 1e-3)
    q = o["joint_q"] + 0.01                                    # the shape moves while loading
    h.inputs.joint_q = q
    y = h.outputs(0.012)
    assert y["phase"][0] == SettlePhase.LOADING and y["gravity"][0] == 0.0
    assert np.isnan(y["hold_time"][0])
    np.testing.assert_array_equal(y["setpoint"][~h.c._screw | (h.c.p.screw_hold == "angle")], q[~h.c._screw])
    for i in range(12, 16):
        h.update(i * 1e-3)
    h.inputs.joint_q = q + 0.02                                # after the latch the set-points stay
    y = h.outputs(0.016)
    assert y["phase"][0] == SettlePhase.HOLDING and y["gravity"][0] == 1.0
    assert y["hold_time"][0] == pytest.approx(0.015)
    np.testing.assert_allclose(y["setpoint"][~h.c._screw], q[~h.c._screw])


P = "placement-scene/"


@pytest.mark.parametrize("scene, duration", [("placement-tube", 1.8), ("placement-walls", 2.0)])
def test_eels15_settles_with_every_screw_within_1mm(scene, duration):
    r = load_session(scene, sim_overrides={"duration": duration}).run()
    T, ph = r["t"], r[P + "settle.phase"][:, 0]
    latched = np.flatnonzero(ph != SettlePhase.SETTLING)
    assert latched.size, f"{scene} did not settle in {duration} s"
    i = latched[0] - 1                                       # the last settling sample
    gap = r[P + "settle.gap"][i]
    # contact: each screw's nearest sample within 1 mm of the wall, penetration at most the static band of
    # the penalty model (k = 1e5 N/m: 1 mm carries 100 N per sample, far above the springs' pull)
    assert np.all(gap <= 1e-3) and np.all(gap >= -1e-3), gap
    assert r[P + "settle.max_speed"][i, 0] <= 5e-3
    assert r[P + "settle.settle_time"][-1, 0] == pytest.approx(T[latched[0]], abs=2e-3)


@pytest.mark.slow
@pytest.mark.parametrize("scene, duration, need", [("placement-u-channel", 0.6, 4), ("placement-dem", 4.5, 6)])
def test_settles_in_u_channel_and_on_dem(scene, duration, need):
    # DEM: EELS 1.0's two screws per module are one rigid body, so the scene asks 6 of 8 in the band
    r = load_session(scene, sim_overrides={"duration": duration}).run()
    latched = np.flatnonzero(r[P + "settle.phase"][:, 0] != SettlePhase.SETTLING)
    assert latched.size, f"{scene} did not settle in {duration} s"
    gap = r[P + "settle.gap"][latched[0] - 1]
    assert np.sum((gap <= 1e-3) & (gap >= -1e-3)) >= need, gap
