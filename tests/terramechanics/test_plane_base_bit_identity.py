"""The soil's base (a DEM or a plane under the soil, the normal-direction law of deformable_kernels.py) leaves
every soil scene on level ground bit-identical: on a plane base N = ẑ and cos α = 1 exactly, and the kernels
keep the level case's arithmetic (the vertical lines through the nodes, the same sums in the same order).

The fingerprints in data/plane_base_signals.json were computed by commit c87607b, before the base existed, with
tests/thermal/scene_signals.py's ``run`` and ``fingerprint`` (every recorded signal of the scene, 0.6 s, its own
settings); here today's code recomputes them. A later change that alters one of these scenes on purpose ends
what this can show for it: drop the scene (saying why), never rewrite its fingerprint from today's code."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "thermal"))
from scene_signals import fingerprint, run  # noqa: E402

REFERENCE = json.loads((Path(__file__).with_name("data") / "plane_base_signals.json").read_text())


@pytest.mark.slow
@pytest.mark.parametrize("scene", sorted(REFERENCE["scenes"]))
def test_soil_scene_on_level_ground_is_bit_identical_to_the_code_before_the_base(scene):
    duration = REFERENCE["scenes"][scene]["duration_s"]
    result = run(scene, duration)
    assert np.nanmax(result.log["contact.normal_force"]) > 1.0        # the soil carries the robot: its code ran
    assert fingerprint(result, duration) == REFERENCE["scenes"][scene]
