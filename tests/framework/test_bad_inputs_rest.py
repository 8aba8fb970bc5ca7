"""Issue 27, item 5: the rest of the bad inputs, each a clear error (file, key, value, what is valid)
or the right behaviour, through the real command line where the case is a command-line one."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from click.testing import CliRunner

from snakesim.framework import Params as BaseParams
from snakesim.framework.cli import cli
from snakesim.framework.errors import ConfigError

PEND = """
sim: {duration: 0.01, dt: 0.001}
components:
  NAME: {type: pendulum}
record: [NAME.theta]
"""


def _run(*args):
    r = CliRunner().invoke(cli, [str(a) for a in args])
    return r.exit_code, r.output


# -- a URDF mesh that is not a mesh: named by link and file -----------------------------------

HULL_SCENE = """
sim: {duration: 0.002, dt: 0.001}
components:
  terrain: {type: terrain, params: {name: flat-ice}}
  robot: {type: multibody, params: {design: eels-1.0, modules: 2, urdf: URDF, base_position: [0, 0, 0.0898]}}
  contact: {type: hull_contact}
connections:
  - terrain.terrain -> contact.terrain
  - robot.link_poses -> contact.link_poses
  - robot.link_velocities -> contact.link_velocities
  - contact.wrenches -> robot.wrenches
record: [robot.com]
"""


@pytest.fixture(scope="module")
def eels_urdf(tmp_path_factory):
    d = tmp_path_factory.mktemp("urdf")
    code, out = _run("robot", "urdf", "--robot", "eels-1.0", "--modules", "2", "-o", d / "r.urdf")
    assert code == 0, out
    return d, (d / "r.urdf").read_text()


@pytest.mark.parametrize("mesh, expect", [
    ("/etc/passwd", "mesh '/etc/passwd' is not a mesh file (type 'none')"),
    ("junk.stl", "cannot be read as STL (a binary or corrupt file?"),
])
def test_a_urdf_mesh_that_is_not_a_mesh_is_named_by_link_and_file(eels_urdf, mesh, expect):
    d, text = eels_urdf
    (d / "junk.stl").write_bytes(os.urandom(3000))
    i = text.index('<link name="screw_front_link_00">')
    j = text.index("<cylinder", i)
    k = text.index("/>", j) + 2
    bad = d / f"bad-{mesh.replace('/', '_')}.urdf"
    bad.write_text(text[:j] + f'<mesh filename="{mesh}"/>' + text[k:])
    scene = d / "hull.yaml"
    scene.write_text(HULL_SCENE.replace("URDF", str(bad)))
    code, out = _run("run", scene, "--quiet")
    assert code == 1, out
    assert "Traceback" not in out and "charset_normalizer" not in out
    assert f"{bad}: link 'screw_front_link_00' <collision> #1: " in out
    assert expect in out
    assert "valid: a triangle mesh file (.stl, .obj" in out


def test_a_viewer_mesh_that_is_not_a_mesh_is_skipped_naming_link_and_file(tmp_path, capsys):
    from snakesim.components.viz.robot_geometry import meshes_from_urdf

    (tmp_path / "junk.stl").write_bytes(os.urandom(2000))
    urdf = ('<robot name="r"><link name="body"><visual><geometry><mesh filename="junk.stl"/></geometry>'
            '</visual></link></robot>')
    meshes_from_urdf(urdf, tmp_path)
    err = capsys.readouterr().err
    assert "link 'body' <visual>: mesh 'junk.stl'" in err and "cannot be read as STL" in err
    assert "shown without it" in err


# -- fit-friction on a binary file: the YAML reader's message ---------------------------------

def test_fit_friction_on_a_binary_file_says_not_utf8_text(tmp_path):
    data = tmp_path / "drag.csv"
    data.write_bytes(b"normal_force,direction\n\x9b\xff\x00binary")
    code, out = _run("fit-friction", data)
    assert code == 1 and "Traceback" not in out
    assert f"{data}: not UTF-8 text: byte 0x9b at byte offset 23" in out
    assert "a drag-test CSV is UTF-8 text (a binary file?)" in out
    yaml_file = tmp_path / "scene.yaml"
    yaml_file.write_bytes(b"normal_force,direction\n\x9b\xff\x00binary")
    code, out_yaml = _run("run", yaml_file)
    assert "not UTF-8 text: byte 0x9b at byte offset 23" in out_yaml         # the same wording


# -- huge_num: a parameter whose square overflows in setup ------------------------------------

def test_a_parameter_that_overflows_in_setup_is_named_by_component_and_key(tmp_path):
    code, out = _run("run", "pendulum", "--set", "components.pend.params.length=1e300", "--quiet")
    assert code == 1 and "Traceback" not in out
    assert "components.pend.params.length: pend: parameter length = 1e+300 is out of range" in out
    assert "valid: a magnitude between 1e-100 and 1e100" in out


def test_an_overflow_in_setup_names_the_component_when_no_parameter_stands_out():
    from snakesim.framework import Component
    from snakesim.framework.component import SetupNumberError

    class Squares(Component):
        class Params(BaseParams):
            x: float = 1e200

        def setup(self):
            self.y = self.p.x ** 2

    with pytest.raises(SetupNumberError) as e:
        Squares("sq")
    assert e.value.key == "x" and "sq: parameter x = 1e+200" in str(e.value)

    class Numpy(Component):
        def setup(self):
            import numpy as np
            self.y = np.float64(1e300) * np.float64(1e300)     # numpy overflows: an error in setup, not an inf

    with pytest.raises(SetupNumberError) as e:
        Numpy("np1")
    assert e.value.key is None and "np1: setup of Numpy failed on a number out of range" in str(e.value)


# -- sim: 5 (not a mapping) -------------------------------------------------------------------

def test_sim_not_a_mapping_is_an_error_in_the_assembly(tmp_path):
    scene = tmp_path / "s.yaml"
    scene.write_text(PEND.replace("NAME", "pend").replace("sim: {duration: 0.01, dt: 0.001}", "sim: 5"))
    code, out = _run("run", scene, "--duration", "0.01", "--quiet")      # a flag layer must not hide it
    assert code == 1
    assert f"{scene}:2: sim: 'sim' must be a mapping, got a number: '5'; valid keys: duration, dt, integrator" in out


def test_sim_not_a_mapping_is_an_error_in_a_config_file_and_a_set(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("description: x\nsim: 5\n")
    code, out = _run("run", "pendulum", "--config", cfg, "--duration", "0.01", "--quiet")
    assert code == 1 and f"{cfg}:2: sim: 'sim' must be a mapping" in out
    code, out = _run("run", "pendulum", "--set", "sim=5", "--duration", "0.01", "--quiet")
    assert code == 1 and "--set: sim: 'sim' must be a mapping" in out


# -- component names --------------------------------------------------------------------------

@pytest.mark.parametrize("name, bad", [("a.b c/pend", "' ', '.'"), ("x,y", "','"), ("a->b", "'>'"),
                                       ("a//b", "an empty part")])
def test_a_component_name_that_cannot_be_referenced_is_refused(tmp_path, name, bad):
    scene = tmp_path / "n.yaml"
    scene.write_text("sim: {duration: 0.01, dt: 0.001}\ncomponents:\n  \"%s\": {type: pendulum}\n" % name)
    code, out = _run("run", scene, "--quiet")
    assert code == 1
    assert f"{scene}:3: components.{name}: component name '{name}' is not a valid name" in out
    assert bad in out
    assert "letters, digits, '_' and '-', with '/' between an include's prefix and the name" in out


def test_an_include_prefix_that_cannot_be_referenced_is_refused(tmp_path):
    scene = tmp_path / "i.yaml"
    scene.write_text("include:\n  - {assembly: pendulum, as: \"a.b c\"}\n")
    code, out = _run("run", scene, "--quiet")
    assert code == 1 and f"{scene}:2: include[0].as: include prefix 'a.b c' is not a valid name" in out


def test_valid_names_still_build(tmp_path):
    scene = tmp_path / "ok.yaml"
    scene.write_text(PEND.replace("NAME", "pend-1_B"))
    code, out = _run("run", scene, "--quiet")
    assert code == 0, out


# -- --integrator with --set sim.integrator.params ------------------------------------------

def test_integrator_flag_keeps_the_set_params_and_validates_them(tmp_path):
    code, out = _run("run", "pendulum", "--integrator", "dopri5", "--set", "sim.integrator.params.rtol=-1",
                     "--duration", "0.01", "--quiet")
    assert code == 1
    assert "sim.integrator.params" in out and "dopri5" in out
    assert "rtol" in out and "greater than 0" in out
    saved = tmp_path / "c.yaml"
    code, out = _run("run", "pendulum", "--integrator", "dopri5", "--set", "sim.integrator.params.rtol=1e-3",
                     "--duration", "0.01", "--quiet", "--save-config", saved)
    assert code == 0, out
    text = saved.read_text()
    assert "name: dopri5" in text and "rtol: 0.001" in text


def test_integrator_flag_wins_over_a_set_naming_another():
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry

    paths = default_registry().assembly_paths()
    r = resolve("pendulum", search_path=paths, overrides=["sim.integrator.name=rk4"],
                sim_overrides={"integrator": "dopri5"})
    assert r.sim.integrator.name == "dopri5" and r.sim.integrator.params == {}
    r = resolve("pendulum", search_path=paths, overrides=["sim.integrator.params.rtol=0.01"],
                sim_overrides={"integrator": "dopri5"})
    assert r.sim.integrator.name == "dopri5" and r.sim.integrator.params == {"rtol": 0.01}


# -- a camera model switched in --config replaces the scene's ----------------------------------

def test_a_camera_model_switch_replaces_the_model_block():
    from snakesim.framework.layering import merge_layer
    from snakesim.framework.yaml_source import load_yaml_text

    base = load_yaml_text("components:\n  cam:\n    params:\n      model: {kind: pinhole, fov: 90}\n", "scene.yaml")
    over = load_yaml_text("components:\n  cam:\n    params:\n      model: {kind: cahv, c: [0, 0, 0]}\n", "mine.yaml")
    model = merge_layer(base, over)["components"]["cam"]["params"]["model"]
    assert dict(model) == {"kind": "cahv", "c": [0, 0, 0]}           # no pinhole fov carried over
    same = load_yaml_text("components:\n  cam:\n    params:\n      model: {kind: pinhole, fov: 60}\n", "m.yaml")
    assert dict(merge_layer(base, same)["components"]["cam"]["params"]["model"]) == {"kind": "pinhole", "fov": 60}
    # a gait's kind is one of its params, which the other kinds share: those still merge key by key
    gait = load_yaml_text("components:\n  gait:\n    params: {kind: undulation, amplitude: 0.5}\n", "scene.yaml")
    switch = load_yaml_text("components:\n  gait:\n    params: {kind: sidewinding}\n", "mine.yaml")
    assert dict(merge_layer(gait, switch)["components"]["gait"]["params"]) == {"kind": "sidewinding", "amplitude": 0.5}


def test_a_camera_model_in_config_is_blamed_only_for_its_own_keys(tmp_path):
    cfg = tmp_path / "cam.yaml"
    cfg.write_text("components:\n  stereo:\n    params:\n      model: {kind: fisheye, f: 200, cx: 320}\n")
    code, out = _run("run", "perception-obstacle-course", "--config", cfg, "--duration", "0.01", "--quiet")
    assert code == 1
    assert f"{cfg}:2: components.stereo" in out
    assert "fov" not in out.replace("give fov (degrees) or", "")          # the scene's pinhole fov is gone
    assert "missing cy" in out


# -- --quiet: a failed run says why ------------------------------------------------------------

def test_quiet_failed_run_prints_the_reason():
    r = CliRunner().invoke(cli, ["run", "pendulum", "--set", "components.pend.params.theta0=4",
                                 "--duration", "0.01", "--quiet"])
    assert r.exit_code == 10
    assert "stop condition: pendulum went over the top" in r.stderr
    assert "failure (stop_rule): exit status 10" in r.stderr
    assert r.stdout == ""


def test_quiet_successful_run_prints_nothing():
    r = CliRunner().invoke(cli, ["run", "pendulum", "--duration", "0.01", "--quiet"])
    assert r.exit_code == 0 and r.output == ""


# -- warnings start on a new line, not on the progress bar's ----------------------------------

PROGRESS_SCRIPT = """
import logging, sys, warnings
from snakesim.framework.cli import _progress
under = sys.stderr
with _progress() as progress:
    progress(0.5, 1.0)
    warnings.warn("something odd", RuntimeWarning)
    progress(0.75, 1.0)
    logging.getLogger("snakesim.run").warning("realtime: behind")
    progress(1.0, 1.0)
assert sys.stderr is under, "the guard is gone after the run"
"""


def test_a_warning_during_progress_starts_on_its_own_line():
    # a process of its own: Python's own warning and logging output, not pytest's capture
    r = subprocess.run([sys.executable, "-c", PROGRESS_SCRIPT], capture_output=True, timeout=60)
    text = r.stderr.decode()                       # bytes: the \r kept as written
    assert r.returncode == 0, text
    line = "  [###############               ]  50.0%  t = 0.50 / 1.00 s"
    clear = "\r" + " " * len(line) + "\r"
    assert text.startswith("\r" + line + clear)                  # cleared before the warning...
    assert "RuntimeWarning: something odd" in text[len("\r" + line + clear):].split("\n")[0]   # ...on its own line
    after75 = text.split("75.0%  t = 0.75 / 1.00 s", 1)[1]
    assert after75.startswith(clear + "realtime: behind\n")       # a log record too
    assert text.endswith("100.0%  t = 1.00 / 1.00 s")
