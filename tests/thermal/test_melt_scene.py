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


def watch(**params):
    robot = RobotModel.load(design="eels-1.5", modules=4)
    h = Harness(MeltClimbWatch, {"dwell": 2.0, "window": 1.0, "min_climb": 0.05, **params}, rate=10.0,
                uses={"robot": robot})
    poses = np.zeros((robot.nl, 7))
    poses[:, 4], poses[:, 6] = -np.sqrt(0.5), np.sqrt(0.5)  # −90° about y: every body axis (x) vertical
    h.inputs.link_poses = poses
    h.inputs.penetration = [0.0, 0.021, 0.0, 0.0]
    return h, poses


def test_judge_names_the_melt_in_failure_with_the_dwell_and_depth():
    h, poses = watch()
    for k in range(40):
        h.update(k / 10)
    assert h.c._stop.kind == "mobility"
    assert h.c._stop.reason.startswith("screws melted in: climb failed after dwell 2 s")
    assert "climbed 0 mm in 1 s" in h.c._stop.reason and "21.0 mm" in h.c._stop.reason
    assert h.outputs()["judged"][0] == -1.0


def test_judge_names_a_brace_that_tilts_over_after_the_dwell():
    h, poses = watch()
    for k in range(25):
        h.update(k / 10)
    assert h.c._stop.reason is None
    poses[:, 3:7] = [0.0, 0.0, 0.0, 1.0]                    # every module horizontal: 90° from the vertical
    h.inputs.link_poses = poses
    h.update(2.5)
    assert h.c._stop.kind == "mobility" and "tilted 90.0 deg" in h.c._stop.reason
    assert h.c._stop.reason.startswith("screws melted in: climb failed after dwell 2 s")


def test_judge_passes_a_climb_and_ends_the_run_as_a_success():
    h, poses = watch()
    for k in range(40):
        poses[:, 2] = max(0.0, k / 10 - 2.0) * 0.2          # climbs at 0.2 m/s after the dwell
        h.inputs.link_poses = poses
        h.update(k / 10)
    assert h.c._stop.outcome == "success" and h.outputs()["judged"][0] == 1.0
    assert h.outputs()["climb"][0] == pytest.approx(0.06, abs=1e-9)        # made at the first sample past 5 cm
