"""The snow scene at the settings a user gets (rosenbrock_w at 20 ms, the contact's Jacobian doing the
stiff shear): it settles onto the soil and starts to drive, stably.

Checks from the model, not from a recorded run: at rest the soil carries the robot's weight (Σ F_n = m g
once the settle's transient has decayed), every screw carries part of it and none is buried (0 < sinkage
< 2 r: the Bekker pressure at s = r, (k_c / 2r + k_φ) rⁿ ≈ 4.7 kPa over a screw's footprint, carries
far more than its share); driven, the screws slip forward (0 < s < 1: the thread needs slip to shear the
soil) and the tail moves along the crescent's chord (+x, the schedule's first phase); the run's report
shows the rut it left.
"""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.framework.session import load_session

G = 9.81


def test_snow_scene_settles_and_drives_stably_at_its_own_settings(tmp_path):
    s = load_session("snow-screw-traverse", overrides=["settle=0.8"], sim_overrides={"duration": 1.3})
    result = s.run(out_dir=tmp_path / "run")
    assert result.summary["outcome"] == "success"
    assert result.summary["dt_s"] == 0.02 and "rosenbrock_w" in str(result.summary["integrator"])
    model = s.plan.components["robot"].dyn.model
    weight = sum(inertia.mass for inertia in model.inertias) * G
    t = result["t"]
    rest = (t > 0.6) & (t < 0.8)                                    # settled, screws idle
    driven = t > 1.1                                                # 0.3 s into the forward phase
    fn = result["contact.normal_force"][:, 0]
    assert np.abs(fn[rest] / weight - 1.0).max() < 0.05
    assert np.all(result["contact.screw_normal_force"][rest] > 0.0)
    sink = result["contact.screw_sinkage"]
    assert np.all(sink[rest] > 0.0) and np.all(sink < 2 * 0.09)        # EELS 1.0's screw radius: 0.09 m
    slip = result["contact.screw_slip"][driven]
    assert np.all((slip > 0.0) & (slip < 1.0))
    x = result["tail_pose.pose"][:, 0]
    assert x[-1] - x[rest][-1] > 0.005
    # the report: a rut where the screws pressed, its plastic depth s − σ/K_e below their deepest sinkage
    rep = result.summary["reports"]["contact"]
    rut = rep["rut"]
    assert rut["deformed_nodes"] > 0 and 0.0 < rut["max_rut_depth_m"] < max(rep["max_sinkage_m"])
    assert all(0.0 < v < 2 * 0.09 for v in rep["mean_sinkage_m"])
    assert all(0.0 < v < 1.0 for v in rep["mean_slip_driven"])
    # --out keeps the soil: its state file restores the terrain the run ended with, bit for bit, and the rut's
    # picture is there (framework/run_reports.py's write_files)
    from snakesim.components.terrain.deformable_files import load_state

    assert result.summary["files"]["contact"] == ["soil_state.npz", "rut.png"]
    assert (tmp_path / "run" / "rut.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    terrain = s.plan.caches["contact"].terrain
    ended = {k: v.copy() for k, v in terrain.snapshot().items()}
    terrain.restore({k: np.zeros_like(v) if k in ("plastic", "yield_p") else v for k, v in ended.items()})
    assert not np.array_equal(terrain.snapshot()["plastic"], ended["plastic"])      # the rut wiped
    load_state(terrain, tmp_path / "run" / "soil_state.npz")
    assert all(np.array_equal(terrain.snapshot()[k], ended[k]) for k in ended)


def _drop(height: float, sim_overrides: dict, overrides: list[str]):
    """snow-screw-traverse's robot released ``height`` m above its start (screws just touching the snow), screws
    idle: (t, centre of mass [n, 3], Σ F_n [n], mass kg, summary)."""
    s = load_session("snow-screw-traverse", overrides=[
        "settle=3.0", f"components.robot.params.base_position=[0.0, 0.0, {0.0898 + height}]",
        "record=[robot.com, contact.normal_force]", *overrides], sim_overrides={"duration": 1.5, **sim_overrides})
    r = s.run()
    model = s.plan.components["robot"].dyn.model
    return r["t"], r["robot.com"], r["contact.normal_force"][:, 0], sum(i.mass for i in model.inertias), r.summary


def test_a_drop_onto_the_snow_at_the_scene_settings_lands_where_a_fine_step_does():
    """An impact on the soil at the settings a user gets (error control on a 20 ms base step): the robot
    released 5 cm above the snow falls freely, strikes it (the estimate splits the steps there), sinks deeper
    than a robot set down on it (the fall's m g h goes into more plastic work: a deeper rut) and comes to rest
    carried by the soil (Σ F_n = m g within 2 %). Against fixed 2 ms steps (ten times finer, J at every step):
    the deepest and the resting height of the centre of mass within the scene's own position tolerance
    (atol_q, 1 cm), and the rebound off the compacted rut within 10 % of the fine step's."""
    t, com, fn, m, summary = _drop(0.05, {}, [])
    tf, comf, _, _, summary_f = _drop(0.05, {"dt": 0.002}, ["sim.integrator.params.step_control=fixed",
                                                          "sim.integrator.params.jacobian_every=1"])
    _, gentle, _, _, _ = _drop(0.0, {}, [])
    assert summary["outcome"] == summary_f["outcome"] == "success"
    assert summary["dt_s"] == 0.02 and summary["integrator"]["rejected"] >= 1
    # free fall until the screws meet the snow (the first 5 cm: t = √(2 h / g) ≈ 0.10 s)
    fall = t <= 0.09
    assert np.allclose(com[fall, 2], com[0, 2] - 0.5 * G * t[fall] ** 2, atol=2e-3)
    assert fn[fall].max() == 0.0
    assert com[-1, 2] < gentle[-1, 2] - 0.005
    rest = t > 1.2
    assert np.abs(fn[rest] / (m * G) - 1.0).max() < 0.02
    atol_q = 1e-2
    assert abs(com[:, 2].min() - comf[:, 2].min()) < atol_q
    assert abs(com[-1, 2] - comf[-1, 2]) < atol_q
    rebound = lambda c, tt: np.gradient(c[:, 2], tt)[tt > 0.2].max()          # noqa: E731, m/s upwards
    assert rebound(com, t) == pytest.approx(rebound(comf, tf), rel=0.1)
