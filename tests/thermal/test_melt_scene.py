"""melt-dwell-climb: a short dwell climbs and reports each screw's penetration and temperature; the
scene's melt rate during the dwell is the Stefan / melting-probe rate of its own temperatures, computed
here independently; the melt-in judge names the failure."""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.thermal import MeltClimbWatch
from snakesim.framework import Harness
from snakesim.framework.session import load_session

RHO, LF, CI, TM = 917.0, 334e3, 2100.0, 273.15


@pytest.mark.slow
def test_short_dwell_climbs_and_melts_at_the_stefan_rate():
    r = load_session("melt-dwell-climb", overrides=["dwell=3"]).run()
    s = r.summary
    assert s["outcome"] == "success" and "climb made after dwell 3 s: " in s["stop_reason"]
    heat, watch = s["reports"]["heat"], s["reports"]["watch"]
    assert watch["verdict"] == "climbed" and watch["dwell_s"] == 3.0 and watch["climb_m"] >= 0.1
    assert set(heat["screws"]) == {"screw_front_00", "screw_front_01", "screw_front_02", "screw_front_03"}
    assert all({"penetration_mm", "temperature_C"} <= set(v) for v in heat["screws"].values())
    e = heat["energy_J"]
    assert abs(e["residual"]) < 1e-9 * e["heater_in"] + 1e-9
    # independent Stefan check over the dwell: the depth of ice melted (the ledger's latent heat over
    # ρ L_f A_c, whatever the groove later relaxed as the screws crept) against the melting-probe rate
    # g_c (T − T_m) / (ρ (L_f + c (T_m − T_ice))) integrated here over the recorded temperatures (A_c cancels)
    t, T, d = r.log["t"], r.log["heat.temperature"], r.log["heat.penetration"]
    fn, latent = r.log["contact.screw_normal_force"], r.log["heat.ledger.latent"]
    hold = t <= 3.0
    assert (fn[hold][5:] > 1.0).all()                       # every screw on its wall through the dwell
    rate = 20000.0 * (T[hold] - TM) / (RHO * (LF + CI * (TM - 268.15)))      # m/s, per screw
    stefan = (0.5 * (rate[1:] + rate[:-1]) * np.diff(t[hold])[:, None]).sum()  # trapezoids, 20 Hz record
    melted = latent[hold][-1] / (RHO * LF * 0.115 * 0.01)                   # m, summed over the 4 screws
    assert melted == pytest.approx(stefan, rel=0.01)
    assert (d[hold][-1] <= melted).all()                     # relaxation only takes depth away
    assert d[hold][-1].min() > 5e-4                         # it did melt in: ~3 mm in 3 s


def watch(penetration=(0.0, 0.021, 0.0, 0.0), wall_force=None, **params):
    """The judge on EELS 1.5 standing vertical, its screws at ``penetration`` (m) with 80 N on each wall and the
    walls' μ 1.5: 120 N of traction per screw."""
    robot = RobotModel.load(design="eels-1.5", modules=4)
    h = Harness(MeltClimbWatch, {"dwell": 2.0, "window": 1.0, "min_climb": 0.05, "mu": 1.5, **params}, rate=10.0,
                uses={"robot": robot})
    poses = np.zeros((robot.nl, 7))
    poses[:, 4], poses[:, 6] = -np.sqrt(0.5), np.sqrt(0.5)  # −90° about y: every body axis (x) vertical
    h.inputs.link_poses = poses
    h.inputs.penetration = list(penetration)
    h.inputs.normal_force = [80.0] * 4
    h.inputs.mu_scale = [1.0] * 4
    # groove_drag's F_g = σ_w L (δ − h_t)⁺ with its defaults (1 MPa, h_t 17.5 mm) on EELS 1.5's 0.115 m screws
    h.inputs.wall_force = (list(wall_force) if wall_force is not None
                           else [1e6 * 0.115 * max(d - 0.0175, 0.0) for d in penetration])
    return h, poses


def report(h):
    return h.c.report(h.u.cache, {})


def test_judge_names_embedded_screws_when_a_groove_wall_outholds_the_traction():
    h, poses = watch()                                       # screw 1: 21 mm in, 402.5 N of wall > 120 N
    for k in range(40):
        h.update(k / 10)
    stop = h.c._stop
    assert stop.kind == "mobility" and h.outputs()["judged"][0] == -1.0
    assert stop.reason.startswith("embedded_screws at the dwell's end: screw_front_01 21.0 mm in the ice, "
                                  "thread 17.5 mm: pushing it out of its groove takes 402 N, its traction gives 120 N")
    assert stop.reason.endswith("climbed 0 mm in 1 s, 50 mm needed, dwell 2 s")
    r = report(h)
    assert r["verdict"] == "failed" and r["failure"] == "embedded_screws"
    assert r["at_failure"]["wall_force_N"][1] == pytest.approx(402.5)
    assert r["at_failure"]["traction_N"] == pytest.approx([120.0] * 4)


def test_judge_names_sunk_screws_when_the_brace_tilts_over_within_the_thread():
    h, poses = watch(penetration=(0.012, 0.013, 0.010, 0.011))   # within the 17.5 mm thread: no wall force
    for k in range(25):
        h.update(k / 10)
    assert h.c._stop.reason is None
    poses[:, 3:7] = [0.0, 0.0, 0.0, 1.0]                    # every module horizontal: 90° from the vertical
    h.inputs.link_poses = poses
    h.update(2.5)
    stop = h.c._stop
    assert stop.kind == "mobility" and "tilted 90.0 deg" in stop.reason
    assert stop.reason.startswith("sunk_screws at the dwell's end: screw_front_01 13.0 mm in the ice")
    assert "the brace lost its shape (mobility failure: " in stop.reason
    assert report(h)["failure"] == "sunk_screws" and report(h)["at_failure"]["max_tilt_deg"] == pytest.approx(90.0)


def test_a_failure_without_melt_in_is_not_named_a_melt_in():
    h, poses = watch(penetration=(0.001, 0.002, 0.0, 0.0))
    for k in range(40):
        h.update(k / 10)
    assert h.c._stop.reason.startswith("climb_failed at the dwell's end: screw_front_01 2.0 mm in the ice")
    assert report(h)["failure"] == "climb_failed"


def test_a_groove_wall_the_traction_overcomes_does_not_hold_the_screw():
    h, poses = watch(wall_force=(0.0, 119.0, 0.0, 0.0))    # 119 N of wall against 120 N of traction
    for k in range(40):
        h.update(k / 10)
    assert report(h)["failure"] == "sunk_screws"


def test_judge_passes_a_climb_and_ends_the_run_as_a_success():
    h, poses = watch()                                      # embedded as in the first test, but it climbs
    for k in range(40):
        poses[:, 2] = max(0.0, k / 10 - 2.0) * 0.2          # climbs at 0.2 m/s after the dwell
        h.inputs.link_poses = poses
        h.update(k / 10)
    assert h.c._stop.outcome == "success" and h.outputs()["judged"][0] == 1.0
    assert h.outputs()["climb"][0] == pytest.approx(0.06, abs=1e-9)        # made at the first sample past 5 cm
    r = report(h)
    assert r["verdict"] == "climbed" and "failure" not in r
