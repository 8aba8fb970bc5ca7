"""The one material schema (snakesim.components.materials): validation messages, the packed
table the kernels read by named columns, and a `fit-friction --out` file included by a
terrain file, run in the default scene."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from pydantic import ValidationError

from snakesim.components.contact import ScrewSdfContact, sdf_kernels
from snakesim.components.contact.friction_fit_cli import fit_friction as fit_cmd
from snakesim.components.materials import (C, COLUMNS, EV_A, EV_B, K, MU, Material, MaterialPatch,
                                           material_table)
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.terrain import load_terrain
from snakesim.framework import ConfigError, Harness
from snakesim.framework.registry import default_registry
from snakesim.framework.session import load_session

MODEL = RobotModel.load(design="eels-1.0", modules=2, head=False)


def test_kernels_read_the_materials_columns():
    assert (K, C, MU, EV_A, EV_B) == (0, 1, 2, 3, 4)
    assert [COLUMNS[i] for i in (K, C, MU, EV_A, EV_B)] == ["k", "c", "mu", "ev_a", "ev_b"]
    # the SDF kernels index the table with the same constants
    assert (sdf_kernels.K, sdf_kernels.C, sdf_kernels.MU, sdf_kernels.EV_A, sdf_kernels.EV_B) == (K, C, MU, EV_A, EV_B)
    mats = [Material(name="a", k=1e5, c=1e3, mu=0.3, ev_a=2.0, ev_b=0.01), Material(name="b", k=2e5, c=0.0, mu=0.0)]
    t = material_table(mats, fn_max=500, ev_floor=1e-3)
    assert t.shape == (2, 5) and t.dtype == np.float64 and t.flags.c_contiguous
    for i, m in enumerate(mats):
        for col, field in zip((K, C, MU, EV_A, EV_B), ("k", "c", "mu", "ev_a", "ev_b")):
            assert t[i, col] == getattr(m, field)
    patched = material_table(mats, MaterialPatch(ev_a=4.0), fn_max=500, ev_floor=1e-3)
    np.testing.assert_array_equal(patched[:, EV_A], 4.0)
    np.testing.assert_array_equal(np.delete(patched, EV_A, axis=1), np.delete(t, EV_A, axis=1))
    assert mats[0].override(mu=0.1) == Material(name="a", k=1e5, c=1e3, mu=0.1, ev_a=2.0, ev_b=0.01)


@pytest.mark.parametrize("fields,match", [
    (dict(name="rock", k=0.0), r"material 'rock': k = 0 N/m must be > 0 \(penalty stiffness"),
    (dict(name="rock", k=-1e5), r"material 'rock': k = -100000 N/m must be > 0"),
    (dict(name="mud", c=-1.0), r"material 'mud': c = -1 N·s/m must be ≥ 0"),
    (dict(name="ice", mu=-0.1), r"material 'ice': mu = -0.1 must be ≥ 0 \(friction coefficient\)"),
    (dict(name="ice", ev_a=0.0), r"material 'ice': ev_a = 0 must be > 0"),
    (dict(name="ice", ev_b=float("nan")), r"material 'ice': ev_b = nan is not a finite number"),
    (dict(name="ice", stiffness=1e5), r"stiffness"),
])
def test_bad_material_values_name_material_field_and_value(fields, match):
    with pytest.raises(ValidationError, match=match):
        Material(**fields)


@pytest.mark.parametrize("fields, match", [
    (dict(name="snow", albedo=1.2), r"material 'snow': albedo = 1.2 must be in \[0, 1\]"),
    (dict(name="snow", albedo=float("nan")), r"albedo = nan"),
    (dict(name="rock", color=(0.2, 1.5, 0.1)), r"material 'rock': color = \[0.2, 1.5, 0.1\] must be three values in"),
    (dict(name="ice", texture="stripes"), r"texture"),
    (dict(name="ice", texture_size=0.0), r"texture_size"),
])
def test_bad_sensor_fields_name_material_and_value(fields, match):
    with pytest.raises(ValidationError, match=match):
        Material(**fields)


def test_patch_is_the_optional_view_of_material():
    # the contact fields; the sensor fields (albedo, colour, texture) are not contact knobs
    assert set(MaterialPatch.model_fields) == set(COLUMNS)
    with pytest.raises(ValidationError, match=r"material override: mu = -1 must be ≥ 0"):
        MaterialPatch(mu=-1)
    with pytest.raises(ValidationError, match=r"(?s)material\.k.*material override: k = 0 N/m must be > 0"):
        Harness(ScrewSdfContact, {"material": {"k": 0}}, name="contact", uses={"robot": MODEL})


def _evaluate(h, z=0.0895):
    h.inputs.link_poses = np.tile([0.0, 0.0, z, 0.0, 0.0, 0.0, 1.0], (MODEL.nl, 1))
    h.inputs.link_velocities = np.zeros((MODEL.nl, 6))
    h.inputs.joint_v = np.zeros(MODEL.nj)
    return h.outputs()


def test_ev_must_stay_positive_over_the_components_load_range():
    slush = {"kind": "plane", "materials": [{"name": "slush", "ev_a": 1.0, "ev_b": -0.02}]}   # 0 at 50 N
    h = Harness(ScrewSdfContact, {"fn_max": 100}, name="contact", uses={"robot": MODEL})
    h.inputs.terrain = load_terrain(slush)
    with pytest.raises(ConfigError, match=r"contact: material 'slush': ‖e_v‖ = ev_a \+ ev_b·F_n = 1 − 0\.02·F_n "
                                          r"falls to -1 at F_n = 100 N.*fn_max = 100"):
        _evaluate(h)
    h = Harness(ScrewSdfContact, {"fn_max": 40}, name="contact", uses={"robot": MODEL})   # 0.2 at 40 N: fine
    h.inputs.terrain = load_terrain(slush)
    _evaluate(h)


def _drag_tests(path, mu=0.2, a=2.5, b=0.01):
    rows = ["normal_force,direction,drag_force"]
    for fn in (10.0, 20.0, 40.0, 80.0):
        rows += [f"{fn!r},parallel,{mu * fn!r}", f"{fn!r},normal,{mu * (a + b * fn) * fn!r}"]
    path.write_text("\n".join(rows) + "\n")
    return path


def test_fitted_material_file_included_by_a_terrain_runs_in_the_default_scene(tmp_path):
    # fit-friction writes the file ...
    fitted = tmp_path / "materials" / "glacier.yaml"
    fitted.parent.mkdir()
    res = CliRunner().invoke(fit_cmd, [str(_drag_tests(tmp_path / "glacier-drag-tests.csv")), "--out", str(fitted),
                                       "--k", "1.2e5", "--c", "900"])
    assert res.exit_code == 0, res.output
    # ... a terrain includes it as it is (path relative to the terrain file) ...
    terrain = tmp_path / "glacier-plane.yaml"
    terrain.write_text("kind: plane\nmaterials:\n  - {include: materials/glacier.yaml}\n")
    # ... and the default scene (--terrain PATH) runs on it. Its thread_anisotropy would
    # override ev_a for every terrain material: null leaves the fitted values in force.
    registry = default_registry()
    scene = registry.default_assembly()
    assert scene == "surface-screw-traverse"
    session = load_session(scene, overrides=[f"terrain={terrain}", "thread_anisotropy=null", "robot.modules=2"],
                           sim_overrides={"duration": 0.02}, registry=registry)
    result = session.run()
    assert result.summary["completed"], result.summary
    contact = session.plan.caches["contact"]          # the terrain in use and its packed table: this run's
    (m,) = contact.terrain.materials
    assert m.name == "glacier"
    assert (m.mu, m.ev_a, m.ev_b) == (pytest.approx(0.2, rel=1e-12), pytest.approx(2.5, rel=1e-12),
                                      pytest.approx(0.01, rel=1e-10))
    np.testing.assert_array_equal(contact.mats, [[1.2e5, 900.0, m.mu, m.ev_a, m.ev_b]])
    # physics: the contact on the included terrain gives the forces of the fitted values
    # written inline, not those of the default material
    inline = {"kind": "plane", "materials": [m.model_dump()]}
    forces = {}
    for key, t in (("included", str(terrain)), ("inline", inline), ("default", {"kind": "plane"})):
        h = Harness(ScrewSdfContact, {}, name="contact", uses={"robot": MODEL})
        h.inputs.terrain = load_terrain(t)
        h.inputs.link_poses = np.tile([0.0, 0.0, 0.0895, 0.0, 0.0, 0.0, 1.0], (MODEL.nl, 1))
        h.inputs.link_velocities = np.tile([0.05, 0.02, -0.01, 0.0, 0.0, 0.0], (MODEL.nl, 1))
        h.inputs.joint_v = np.full(MODEL.nj, 1.5)
        forces[key] = h.outputs()["wrenches"].copy()
    assert np.abs(forces["included"]).max() > 0
    np.testing.assert_array_equal(forces["included"], forces["inline"])
    assert not np.allclose(forces["included"], forces["default"])
