"""EELS 1.5 held upright between the 0.35 m walls with gravity on: holds above the friction limit, slides below.

One placement run (gravity off: settle, then the bend pre-load with free joints) gives the state; hold runs start
there at rest with gravity on and differ only by the wall friction μ (components/placement/handoff.py).

Hold limit: the wall forces are along ±y, the weight along −z, so friction must carry m g and can carry at most
μ ΣF_n: μ* = m g / ΣF_n with ΣF_n the wall load of the held state (measured at the start of the hold).
Regularised friction (contact/kernels.py) creeps: a rigid robot sinking at v has friction
μ ΣF_n v/sqrt(v² + v_ε²) = m g, so v = v_ε r/sqrt(1 − r²), r = m g/(μ ΣF_n).
Hold run: μ = 1.35 ≥ 1.5 μ* (asserted with the smallest ΣF_n of the run), v_ε = 2e-4 m/s: r ≤ 1/1.5,
creep ≤ 0.894 v_ε = 0.18 mm/s, 1.8 mm in 10 s, under the 5 mm asked. Slip run: μ = 0.35 ≤ 0.5 μ*; sliding
(v ≫ v_ε) friction is saturated, so the centre of mass accelerates at −g + μ ΣF_n/m.
"""

import numpy as np
import pytest

from snakesim.components.placement import SettlePhase
from snakesim.components.placement.handoff import held_state, hold_overrides
from snakesim.framework.session import load_session

P, H = "placement-scene/", "placement-hold/"
MU_HOLD, MU_SLIP, V_EPS, T_HOLD = 1.35, 0.35, 2e-4, 10.0


@pytest.fixture(scope="module")
def placed():
    s = load_session("placement-walls", sim_overrides={"duration": 2.2})
    r = s.run()
    return s, r, held_state(s, r)


def hold(state, mu, duration):
    s = load_session("placement-walls-hold", overrides=hold_overrides(state) + [f"friction={mu}", f"v_eps={V_EPS}"],
                     sim_overrides={"duration": duration})
    mass = sum(l.mass for l in s.plan.components[H + "robot"].robot.tree.links)
    return s.run(), mass * 9.81, mass


def test_placement_preloads_every_screw_with_a_self_equilibrated_wall_force(placed):
    s, r, _ = placed
    F_pre = s.plan.caches[P + "settle"].preload_forces
    i = np.flatnonzero(r[P + "settle.phase"][:, 0] < SettlePhase.HOLDING)[-1]   # the end of loading: gravity off
    assert r[P + "settle.phase"][i, 0] == SettlePhase.LOADING
    F = r[P + "contact.screw_normal_force"][i]
    # two screws per wall: Σ F n = 0 means equal wall totals; after load_time the walls carry the pre-load
    assert F[[0, 3]].sum() == pytest.approx(F[[1, 2]].sum(), rel=0.02)
    np.testing.assert_allclose(F, F_pre, rtol=0.15)
    assert F_pre.sum() == pytest.approx(4 * 100.0, rel=0.05)


def test_holds_above_the_friction_limit_with_drift_under_the_creep_bound(placed):
    r, mg, _ = hold(placed[2], MU_HOLD, T_HOLD)
    T = r["t"]
    Fn = r[H + "contact.screw_normal_force"].sum(axis=1)
    mu_star = mg / Fn.min()
    assert MU_HOLD >= 1.5 * mu_star, (MU_HOLD, mu_star)
    rr = mg / (MU_HOLD * Fn.min())
    creep = V_EPS * rr / np.sqrt(1 - rr * rr) * T[-1]                # m over the run, the bound
    assert creep < 5e-3
    z = r[H + "robot.link_poses"][:, 2::7]                          # every link origin's height
    tail = abs(z[-1, 0] - z[0, 0])
    assert T[-1] == pytest.approx(T_HOLD) and tail < 5e-3, tail
    # every link: creep plus the elastic take-up of the weight (sub-mm: bends at kp 200 N·m/rad)
    assert np.abs(z[-1] - z[0]).max() < creep + 1e-3
    # the late creep is the regularised law's at the measured wall load
    com = r[H + "robot.com"][:, 2]
    late = T >= T[-1] - 3.0
    v = -(com[-1] - com[late][0]) / (T[-1] - T[late][0])
    rl = mg / (MU_HOLD * Fn[late].mean())
    assert v == pytest.approx(V_EPS * rl / np.sqrt(1 - rl * rl), rel=0.3)
    # held by the joints within their URDF efforts (bend 80, twist 40, screw 20 N·m): not at the clip
    tau = np.abs(r[H + "pid.tau"]).max(axis=0)
    assert tau.max() < 0.6 * 80.0


def test_slides_below_the_friction_limit_at_the_saturated_friction_acceleration(placed):
    r, mg, m = hold(placed[2], MU_SLIP, 0.4)
    T = r["t"]
    Fn = r[H + "contact.screw_normal_force"].sum(axis=1)
    mu_star = mg / Fn[0]
    assert MU_SLIP <= 0.5 * mu_star
    w = T >= 0.1                                                   # sliding: v ≫ v_ε after the first 0.1 s
    a = 2 * np.polyfit(T[w], r[H + "robot.com"][w, 2], 2)[0]
    a_pred = -9.81 + MU_SLIP * Fn[w].mean() / m
    assert a == pytest.approx(a_pred, abs=0.02 * 9.81)
    z = r[H + "robot.link_poses"][:, 2]
    # from rest, at least the saturated-friction fall after the 0.1 s start: ½ g (1 − μ/μ*) (t − 0.1)²
    assert z[0] - z[-1] > 0.5 * 9.81 * (1 - MU_SLIP / mu_star) * (T[-1] - 0.1) ** 2
