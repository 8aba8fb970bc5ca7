"""melt-dwell-climb-ice-friction (issue 28): the walls brace pre-loaded so that ice on ice's friction holds it.

The scene's state and torques are recomputed here from melt-dwell-climb's pose (brace_preload.walls_preload,
placement.handoff.gravity_preload); the run holds the dwell within the vertical-mobility evaluation's drift
tolerance and gives the contact the table's μ."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from snakesim.components.thermal.brace_preload import G, required_preload, walls_preload
from snakesim.components.thermal.ice_friction import ice_mu
from snakesim.components.thermal.ice_friction_data import MU_K, SPEEDS, TEMPERATURES

ASSEMBLIES = Path(__file__).resolve().parents[2] / "assemblies"
MASS = 29.4            # kg, EELS 1.5 with 4 modules (the URDF's links)
DRIFT = 0.005          # m, vertical_mobility_evaluation's drift_tolerance: a hold that moves less is still


def params(name):
    p = yaml.safe_load((ASSEMBLIES / f"{name}.yaml").read_text())["parameters"]
    p["q"] = [float(v) for v in p["q"]]          # YAML 1.1 reads 1e-06 as a string
    p["pose"] = {k: [float(v) for v in w] for k, w in p["pose"].items()}
    return p


@pytest.fixture(scope="module")
def robot_and_walls():
    from snakesim.components.multibody.robot_model import RobotModel
    from snakesim.components.terrain import load_terrain

    return RobotModel.load(design="eels-1.5", modules=4), load_terrain("parallel-walls-0.35")


def test_required_preload_is_the_weight_over_mu():
    assert required_preload(MASS, 0.15, 1.0) == pytest.approx(MASS * 9.81 / 0.15)     # 1923 N
    assert required_preload(MASS, 0.72, 1.5) == pytest.approx(1.5 * 288.414 / 0.72)
    with pytest.raises(ValueError, match="mu"):
        required_preload(MASS, 0.0)


def test_scene_state_is_the_gravity_preload_of_the_walls_brace(robot_and_walls):
    robot, walls = robot_and_walls
    base, var = params("melt-dwell-climb"), params("melt-dwell-climb-ice-friction")
    w = walls_preload(robot, base["q"], base["pose"], walls, var["preload"])
    assert var["q"] == pytest.approx(w.q, abs=1e-6)
    for k in ("position", "quaternion"):
        assert var["pose"][k] == pytest.approx(w.pose[k], abs=1e-6)
    assert var["torque_pattern"] == pytest.approx(w.torques, abs=1e-3)
    assert w.loads.sum() == pytest.approx(var["preload"], rel=1e-6) and (w.loads > 0).all()
    # pressed N/k into the walls (k 1e5 N/m); the last refinement aimed at the previous pass's loads, which the
    # second pre-load moves by < 0.3 %: a few µm
    assert w.depth == pytest.approx(w.loads / 1.0e5, abs=5e-6)
    assert var["target"] == pytest.approx(0.8 * w.loads.min(), abs=0.1)
    # sized for the ice: the least μ of the table at the scene's ice (clipped to 98 K) over every speed, against
    # the friction the hold needs, with a margin; and within the bends' 80 N·m
    least = ice_mu(var["ice_temperature"], SPEEDS).min()
    assert least == pytest.approx(MU_K[0].min()) and least / w.friction > 1.5
    assert max(abs(v) for k, v in w.torques.items() if k.startswith("bend")) < 80.0
    # the free robot's friction must carry the weight: μ_needed ΣF_n ≥ m g
    assert w.friction * w.loads.sum() >= MASS * G * (1 - 1e-6)


def test_on_glacier_ice_the_same_brace_needs_more_than_the_bends_give(robot_and_walls):
    """−5 °C ice (the table's 263 K row): least μ 0.15; the hold needs ~2900 N, past 80 N·m in the bends."""
    robot, walls = robot_and_walls
    base = params("melt-dwell-climb")
    least = MU_K[np.searchsorted(TEMPERATURES, 263.0)].min()
    total = required_preload(MASS, least, 1.5)
    w = walls_preload(robot, base["q"], base["pose"], walls, total)
    assert least == 0.15 and w.friction < least
    assert max(abs(v) for k, v in w.torques.items() if k.startswith("bend")) > 2 * 80.0


@pytest.mark.slow
def test_pre_loaded_brace_holds_the_dwell_on_ice_friction_and_the_contact_sees_the_table():
    from snakesim.framework.session import load_session

    var = params("melt-dwell-climb-ice-friction")
    dwell = var["dwell"]
    r = load_session("melt-dwell-climb-ice-friction",
                     sim_overrides={"duration": dwell, "record_rate": 100}).run()
    t, z, fn = r.log["t"], r.log["robot.com"][:, 2], r.log["contact.screw_normal_force"]
    # starts in the solved equilibrium: the walls' loads at t = 0 are the pre-load's (N/k pressed in)
    assert fn[0].sum() == pytest.approx(var["preload"], rel=0.01)
    assert (fn[1:] > 1.0).all()                                   # every screw on its wall through the dwell
    assert t[-1] == pytest.approx(dwell) and np.abs(z - z[0]).max() < DRIFT
    # the μ the contact sees (walls' μ × screw_mu_scale, sampled at 100 Hz) is the table's at 98 K (93 K clipped)
    v, law, scale = r.log["contact.screw_slip_speed"], r.log["ice.mu"], r.log["heat.mu_scale"]
    assert (r.log["heat.temperature"] > 273.15).all()           # heated: no refreeze bond on the law's μ
    assert law == pytest.approx(ice_mu(98.0, v), abs=1e-12) and law.min() >= 0.72 - 1e-12
    assert var["friction"] * scale[1:] == pytest.approx(law[:-1], abs=1e-12)
