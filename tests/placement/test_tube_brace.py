"""Why no body-respecting EELS 1.5 brace in the 0.35 m tube (components/placement/tube_brace.py; issue 15).

Module 1 carries the 0.4 m cross bar (a 0.2 × 0.4 × 0.04 m box across the module, along its bend axis) and the
avionics box. Rigidly joined, that cluster needs a vertical cylinder of radius ~0.2024 m in its best
orientation (module axis vertical, bar horizontal: the bar's horizontal half-diagonal √(0.2² + 0.03²) =
0.202 m, the module body inside it), more than the 0.175 m of vertical-tube-r0.175: in every orientation some
of it is inside the wall, so tube-brace-descend.yaml's robot cannot keep its bodies out (its terrain_clearance
report lists them). The same search returns the bar alone, which fits when upright, as ~0.10 m: the measure can
come out small.
"""

from __future__ import annotations

import numpy as np

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.placement.tube_brace import narrowest_vertical_tube
from snakesim.components.terrain import load_terrain

ROBOT = RobotModel.load(design="eels-1.5", modules=4)


def test_module_one_with_its_cross_bar_does_not_fit_the_035_tube():
    r, R = narrowest_vertical_tube(ROBOT, ["module_01", "cross_bar", "avionics_box"], orientations=100)
    bar_half_diagonal = np.hypot(0.2, 0.02)                  # the bar's 0.4 × 0.04 footprint, horizontal
    assert r > load_terrain("vertical-tube-r0.175").radius + 0.02
    assert bar_half_diagonal - 1e-3 <= r <= bar_half_diagonal + 0.01
    assert abs(R[2, 0]) > np.cos(np.radians(15.0))         # the module upright at the optimum
    alone, _ = narrowest_vertical_tube(ROBOT, ["cross_bar"], orientations=100)
    assert alone < 0.12

