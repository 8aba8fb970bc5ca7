"""Issue 28: with the thermal components absent, existing scenes' results are bit-identical.

The thermal package changed no shared file; the contact-law ports it wires to (per-screw μ and ‖e_v‖ scales
and sinkage in, slip power and slip speed out: components/contact/contact_law.py) went into every contact
back end's force kernels and Jacobians in commit 8635397. The fingerprints in data/pre_contact_law_signals.json
were computed by that commit's parent (2385d88, no such port anywhere) with scene_signals.py, as its docstring
says; here today's code recomputes them: every recorded signal of each scene, bit for bit. A later change
that alters one of these scenes on purpose ends what this can show for it: take the scene out of SCENES
(saying why), never rewrite its fingerprint from today's code."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene_signals import SCENES, fingerprint, run  # noqa: E402

REFERENCE = json.loads((Path(__file__).with_name("data") / "pre_contact_law_signals.json").read_text())


def test_the_reference_was_computed_before_the_contact_law_ports():
    assert REFERENCE["commit"].startswith("2385d88")
    assert set(REFERENCE["scenes"]) == set(SCENES)


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_scene_signals_are_bit_identical_to_the_pre_thermal_code(scene):
    duration = SCENES[scene]
    result = run(scene, duration)
    # the run goes through the code under test: the contact pushes (a scene resting off its terrain would
    # match whatever the contact law computed)
    assert np.nanmax(result.log["contact.normal_force"]) > 1.0
    assert fingerprint(result, duration) == REFERENCE["scenes"][scene]
