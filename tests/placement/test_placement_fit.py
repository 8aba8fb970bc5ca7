"""Shape fit: the fitted robot's bend points lie on the target curve (checked through the multibody's own FK)."""

import numpy as np
import pytest

from snakesim.components.multibody import Multibody
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.placement import PlacementError, Shape, fit_shape
from snakesim.components.placement.fit import curve_distance
from snakesim.components.placement.shapes import world_curve
from snakesim.framework.harness import Harness


def src(design, modules=4):
    return RobotModel.load(design=design, modules=modules)


def bend_points(design, pl, modules=4):
    h = Harness(Multibody, dict(design=design, modules=modules, q0=pl.q0, base_position=pl.base_position,
                                base_quaternion=pl.base_quaternion))
    poses = h.outputs()["link_poses"]
    robot = h.c.robot
    rows = [robot.link_index(robot.tree.joint_by_name[j].child) for j in robot.joints if j.startswith("bend")]
    return poses[rows, :3]


SHAPES = [dict(kind="crescent", radius=-1.2, pose=dict(position=[1, 2, 3], rpy=[0.3, 0.2, 0.1])),
          dict(kind="helix", radius=0.23, pitch=2.0, phase=-1.0),
          dict(kind="s_curve", amplitude=0.18, wavelength=1.75, phase=1.5708)]


@pytest.mark.parametrize("design", ["eels-1.5", "eels-1.0"])
@pytest.mark.parametrize("shape", SHAPES, ids=lambda s: s["kind"])
def test_bend_points_on_curve_for_bend_twist_designs(design, shape):
    # bend + twist per module represents these curves exactly at the vertices (module doc of fit.py)
    pl = fit_shape(src(design), shape)
    assert pl.clipped == ()
    pts = world_curve(Shape(**shape), 10.0, 20001)
    assert curve_distance(pts, bend_points(design, pl)).max() < 1e-5


def test_helix_vertices_at_helix_radius_about_its_axis():
    pl = fit_shape(src("eels-1.5"), SHAPES[1])
    P = bend_points("eels-1.5", pl)
    np.testing.assert_allclose(np.hypot(P[:, 1], P[:, 2]), 0.23, atol=1e-6)
    assert np.hypot(*pl.base_position[1:]) == pytest.approx(0.23, abs=1e-9)


def test_crescent_bends_are_the_chord_turning_angles():
    # chords a, b of a circle of radius R turn by asin(a/2R) + asin(b/2R); the fit's vertices give a, b
    R = 1.5
    pl = fit_shape(src("eels-1.5"), dict(kind="crescent", radius=R))
    V = pl.vertices
    chords = np.linalg.norm(np.diff(V, axis=0), axis=1)
    bends = [pl.q0[f"bend_{i:02d}"] for i in range(4)]
    expect = np.arcsin(chords[:-1] / (2 * R)) + np.arcsin(chords[1:] / (2 * R))
    # the curve is a polyline of ~1.7 mm samples: sagitta h²/8R ≈ 2.5e-7 m over the 0.08 m tail chord
    np.testing.assert_allclose(np.abs(bends), expect, atol=2e-5)
    assert max(abs(pl.q0[f"twist_{i:02d}"]) for i in range(4)) < 1e-9     # planar: no twist needed


def test_straight_is_all_zero_and_joints_kind_passes_q_through():
    pl = fit_shape(src("eels-1.5"), dict(kind="straight", pose=dict(position=[0, 0, 1])))
    assert all(v == 0 for v in pl.q0.values()) and pl.base_position == (0, 0, 1)
    pl = fit_shape(src("eels-1.5"), dict(kind="joints", q={"bend_01": 0.3}))
    assert pl.q0["bend_01"] == 0.3 and pl.q0["bend_00"] == 0.0


def test_pitch_yaw_design_is_approximate_and_says_so():
    # eels-concept: alternating pitch/yaw, no twist: a helix is not representable exactly
    pl = fit_shape(src("eels-concept"), SHAPES[1])
    assert pl.residual > 0.01


@pytest.mark.parametrize("bad, msg", [
    (dict(kind="helix", radius=0.2), "needs pitch"),
    (dict(kind="straight", radius=0.2), "does not read radius"),
    (dict(kind="crescent", radius=0.0), "non-zero"),
    (dict(kind="helix", radius=-0.1, pitch=1.0), "radius > 0"),
])
def test_bad_shape_is_a_clear_error(bad, msg):
    with pytest.raises(ValueError, match=msg):
        Shape(**bad)


def test_curve_too_tight_for_a_module_is_a_clear_error():
    with pytest.raises(PlacementError, match="turns too tightly"):
        fit_shape(src("eels-1.5"), dict(kind="crescent", radius=0.1))


def test_joint_vector_of_wrong_length_is_a_clear_error():
    with pytest.raises(PlacementError, match="DOF joints"):
        fit_shape(src("eels-1.5"), dict(kind="joints", q=[0.0, 0.1]))


def test_placed_multibody_takes_the_fit():
    from snakesim.components.placement import PlacedMultibody

    h = Harness(PlacedMultibody, dict(design="eels-1.5", modules=4, shape=SHAPES[1]))
    pl = fit_shape(src("eels-1.5"), SHAPES[1])
    assert h.c.p.q0 == pl.q0 and h.c.p.base_quaternion == pytest.approx(pl.base_quaternion)
    assert h.outputs()["joint_q"][h.c.dof_index("bend_01")] == pytest.approx(pl.q0["bend_01"])
