"""A robot held still on sloped soil (its screws idle on the snow of snow-field.yaml laid on a 5° plane):
the screw–soil shear is regularised near rest (slope τ_max ℓ / (K v_ε) per node area: contact.py), so under a
load within the soil's capacity it does not stick but creeps, at a speed below v_ε (the viscous branch
carries F = F_max v / v_ε, and F < F_max while it holds). The check: the creep after settling stays under
v_ε at the scene's settings, with its v_ε (1 mm/s) and with the contact's default 10 mm/s — 1 mm/s, which fixed 20 ms steps at that v_ε do not
meet: their linearly implicit stages overshoot the shear's linear range |v| < v_ε and the robot creeps at
7.5 mm/s; the scene's error control splits those steps (docs/terramechanics.md, bench/soft_terrain.py part 7)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

SLOPE = 0.0873                   # rad (5°), rising towards +y: across the crescent's chord


def creep(tmp_path, overrides):
    from snakesim.framework.session import load_session

    text = (Path(__file__).parents[2] / "terrains" / "snow-field.yaml").read_text()
    path = tmp_path / "snow-slope.yaml"
    path.write_text(text.replace("base_height: 0.0", f"base: {{kind: plane, tilt: {SLOPE}, azimuth: 1.5708}}"))
    s = load_session("snow-screw-traverse", overrides=["settle=6.0", f"terrain={path}", *overrides],
                     sim_overrides={"duration": 6.0})
    r = s.run()
    assert r.summary["outcome"] == "success"
    # idle screws held by the PID are not driven: the report has no slip for them (a ratio of jitter)
    assert r.summary["reports"]["contact"]["mean_slip_driven"] == [None] * 20
    t, p = r["t"], r["tail_pose.pose"]
    i = np.searchsorted(t, 2.0)                      # settled
    return float(np.linalg.norm(p[-1, :2] - p[i, :2]) / (t[-1] - t[i]))


@pytest.mark.slow
def test_a_robot_on_a_snow_slope_creeps_slower_than_the_shear_regularisation_allows(tmp_path):
    assert creep(tmp_path, []) < 0.001                                  # the scene's v_ε, 1 mm/s
    assert creep(tmp_path, ["shear_v_eps=0.01"]) < 0.01                # the contact's default, 10 mm/s
