"""One test per build-time error: each message names both ends, or the file, line and key.

Wiring mistakes are made with the Python builder (the line a message cites is the ``connect()`` call's in
this file); the YAML front end's own errors (keys, parameters, includes, templates, ``comp.port`` text)
are made from YAML (the line cited is the scene file's)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from framework_components import IntSource, WrenchSource, WrenchToForce
from snakesim.components.examples.pendulum import Pendulum, ViscousDamper
from snakesim.components.signals.blocks import Gain, ZeroOrderHold
from snakesim.components.signals.sources import Constant
from snakesim.framework import Builder
from snakesim.framework.errors import BuildError, ConfigError, SnakesimError

THIS = Path(__file__).name


def build_error(b: Builder, exc=BuildError) -> str:
    with pytest.raises(exc) as e:
        b.build()
    return str(e.value)


def next_line() -> str:
    """'test_build_errors.py:N' of the line after the caller's: where the builder call below it is written."""
    return f"{THIS}:{sys._getframe(1).f_lineno + 1}"


def line_of(path, needle: str) -> int:
    """1-based line of the first line containing needle (the test's own YAML)."""
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if needle in line:
            return n
    raise AssertionError(needle)


# -- wiring, from the builder ---------------------------------------------------------------------------

MISMATCHED = {
    "shapes": (lambda: (Constant("src", n=3), Gain("g", n=2)), "y", "u",
               ["cannot connect src.y", "-> g.u", "shape (3,)", "shape (2,)", "shapes differ"]),
    "units": (lambda: (Pendulum("pend"), ViscousDamper("damper")), "theta", "omega",
              ["cannot connect pend.theta", "damper.omega", "[rad]", "[rad/s]", "units differ"]),
    "dtypes": (lambda: (IntSource("count"), Gain("g")), "count", "u",
               ["cannot connect count.count", "g.u", "int64", "float64", "dtypes differ"]),
    "structured_to_numeric": (lambda: (WrenchSource("w"), Gain("g")), "w", "u",
                              ["cannot connect w.w (structured Wrench) -> g.u (numeric",
                               "one end is structured, the other numeric"]),
    "structured_types_that_differ": (lambda: (Pendulum("pend"), WrenchToForce("f")), "theta", "w",
                                     ["pend.theta", "f.w (structured Wrench)"]),
}


@pytest.mark.parametrize("make, out, inp, expected", MISMATCHED.values(), ids=list(MISMATCHED))
def test_mismatched_ports_name_both_ends_and_the_line(make, out, inp, expected):
    b = Builder()
    src, dst = b.add(*make())
    at = next_line()
    b.connect(getattr(src.out, out), getattr(dst.inp, inp))
    msg = build_error(b)
    for text in expected + [at]:
        assert text in msg


def test_unconnected_required_input():
    b = Builder()
    g = b.add(Gain("g", n=2))
    b.record(g.out.y)
    msg = build_error(b)
    assert "required inputs are not connected" in msg
    assert "g.u (gain, numeric shape (2,)" in msg
    assert "source.output -> component.input" in msg


def test_input_wired_twice():
    b = Builder()
    a, c, g = b.add(Constant("a"), Constant("b"), Gain("g"))
    first = next_line()
    b.connect(a.out.y, g.inp.u)
    second = next_line()
    b.connect(c.out.y, g.inp.u)
    b.record(g.out.y)
    msg = build_error(b)
    assert "input g.u is wired twice: from a.y" in msg and "from b.y" in msg
    assert first in msg and second in msg


def test_algebraic_loop_shows_the_cycle_of_ports():
    b = Builder()
    a, c = b.add(Gain("a", k=0.5), Gain("b", k=0.5))
    b.connect(a.out.y, c.inp.u)
    b.connect(c.out.y, a.inp.u)
    b.record(a.out.y)
    msg = build_error(b)
    assert "algebraic loop" in msg
    cycle = msg.splitlines()[0].split(": ", 1)[1]
    assert cycle in ("a.y -> b.u ; b.y -> a.u", "b.y -> a.u ; a.y -> b.u")


def test_state_only_output_breaks_the_loop():
    """pend.omega -> damper -> pend.tau is a loop of ports but not an algebraic one."""
    b = Builder(duration=0.01)
    pend, damper = b.add(Pendulum("pend"), ViscousDamper("damper"))
    b.connect(pend.out.omega, damper.inp.omega)
    b.connect(damper.out.tau, pend.inp.tau)
    assert b.build().plan.report["evaluation_order"] == ["pend[theta,omega]", "damper[tau]"]


def test_rate_not_a_whole_number_of_base_steps():
    b = Builder(dt=0.001)
    src, zoh = b.add(Constant("src"), ZeroOrderHold("zoh", rate=300))
    b.connect(src.out.y, zoh.inp.u)
    msg = build_error(b)
    assert "zoh: rate 300 Hz is not an integer number of base steps" in msg
    assert "3.333 steps" in msg and "1000/k Hz" in msg


# -- the YAML front end ---------------------------------------------------------------------------------
# (scene, error, texts in the message ("{path}": the scene file's), lines cited (scene.yaml:N of the first line
# holding each needle), how the message starts (or None))

YAML_ERRORS = {
    "unknown_component_type_with_close_match": ("""
        components:
          pend: {type: pendulm}
        """, ConfigError, ["unknown component type 'pendulm'", "did you mean 'pendulum'", "components.pend.type"],
        ["pend:"], None),
    "unknown_param_key": ("""
        components:
          pend:
            type: pendulum
            params: {lenght: 2.0}
        """, ConfigError, ["components.pend.params.lenght", "unknown parameter", "length", "{path}"], [], None),
    "bad_param_value_names_key_and_value": ("""
        components:
          pend: {type: pendulum, params: {length: -1.0}}
        """, ConfigError, ["components.pend.params.length", "greater than 0", "-1.0"], [], None),
    "yaml_key_error_cites_file_line_and_key": ("""
        description: x
        sim:
          duration: 1.0
          dtt: 0.01
        components:
          pend: {type: pendulum}
        """, ConfigError, [], [], "{path}:4: sim.dtt: unknown key 'dtt'"),
    "bad_sim_value_cites_file_line_and_key": ("""
        sim:
          duration: 1.0
          dt: fast
        components:
          pend: {type: pendulum}
        """, ConfigError, ["'fast'"], [], "{path}:3: sim.dt: "),
    "unknown_top_level_key": ("""
        components:
          pend: {type: pendulum}
        conections:
          - pend.omega -> pend.tau
        """, ConfigError, ["did you mean 'connections'"], [],
        "{path}:3: conections: unknown top-level key 'conections'"),
    "include_of_a_missing_sub_assembly": ("""
        components:
          pend: {type: pendulum}
        include:
          - {assembly: lib/spring-mass-cel}
        """, ConfigError, ["no assembly 'lib/spring-mass-cel'", "Did you mean: lib/spring-mass-cell"],
        ["spring-mass-cel"], None),
    "bad_include_param": ("""
        include:
          - assembly: lib/spring-mass-cell
            params: {mass: 2.0, stiffness: 5.0}
        """, ConfigError, ["'stiffness' is not a parameter of spring-mass-cell.yaml", "it declares: mass, k, c, x0",
                           "include[0].params.stiffness"], ["stiffness"], None),
    "connection_naming_a_missing_port": ("""
        components:
          pend: {type: pendulum}
          damper: {type: viscous_damper}
        connections:
          - pend.omegaa -> damper.omega
          - damper.tau -> pend.tau
        """, BuildError, ["'pend.omegaa'", "pend (pendulum) has no output 'omegaa'; did you mean omega"],
        ["omegaa"], None),
    "connection_naming_a_missing_component": ("""
        components:
          pend: {type: pendulum}
          damper: {type: viscous_damper}
        connections:
          - pendd.omega -> damper.omega
        """, BuildError, ["no component 'pendd'; did you mean pend"], [], None),
    "connection_backwards": ("""
        components:
          pend: {type: pendulum}
          damper: {type: viscous_damper}
        connections:
          - damper.omega -> pend.omega
        """, BuildError, ["'omega' is an input of damper", "output -> input"], [], None),
    "template_error_cites_file_and_line": ("""
        parameters: {k: 2.0}
        components:
          g:
            type: gain
            params: {k: "${kk}"}
        """, ConfigError, ["'${kk}' references 'kk'"], ["kk"], None),
    "unknown_integrator": ("""
        sim: {integrator: rk5}
        components:
          pend: {type: pendulum}
        """, ConfigError, ["unknown integrator 'rk5'", "rk4", "sim.integrator.name"], [], None),
}


@pytest.mark.parametrize("text, exc, expected, lines, starts", YAML_ERRORS.values(), ids=list(YAML_ERRORS))
def test_yaml_errors_cite_file_line_and_key(scene, tmp_path, text, exc, expected, lines, starts):
    path = tmp_path / "scene.yaml"
    with pytest.raises(exc) as e:
        scene(text)
    msg = str(e.value)
    for part in expected:
        assert part.replace("{path}", str(path)) in msg
    for needle in lines:
        assert f"scene.yaml:{line_of(path, needle)}" in msg
    if starts is not None:
        assert msg.startswith(starts.replace("{path}", str(path)))


def test_duration_not_a_whole_number_of_steps(scene):
    s = scene("""
        sim: {duration: 0.0105, dt: 0.001}
        components:
          pend: {type: pendulum}
        """)
    with pytest.raises(SnakesimError, match=re.escape("duration 0.0105 s is not a whole number of steps")):
        s.run()


def test_bad_values_from_set_and_command_line_are_located(scene):
    text = """
        components:
          pend: {type: pendulum}
        """
    with pytest.raises(ConfigError) as e:
        scene(text, overrides=["sim.dt=-1"])
    assert str(e.value).startswith("--set: sim.dt: ") and "greater than 0" in str(e.value)
    with pytest.raises(ConfigError) as e:
        scene(text, sim_overrides={"duration": 0.0})
    assert str(e.value).startswith("command line: sim.duration: ")
