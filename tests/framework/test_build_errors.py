"""One test per build-time error: each message names both ends, or the file, line and key."""

from __future__ import annotations

import re

import pytest

from snakesim.framework.errors import BuildError, ConfigError, SnakesimError


def raises(scene, text, exc=SnakesimError, **kw) -> str:
    with pytest.raises(exc) as e:
        scene(text, **kw)
    return str(e.value)


def line_of(path, needle: str) -> int:
    """1-based line of the first line containing needle (the test's own YAML)."""
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if needle in line:
            return n
    raise AssertionError(needle)


def test_mismatched_shapes(scene, tmp_path):
    msg = raises(scene, """
        components:
          src: {type: constant, params: {n: 3}}
          g: {type: gain, params: {n: 2}}
        connections:
          - src.y -> g.u
        record: [g.y]
        """, BuildError)
    assert "cannot connect src.y" in msg and "-> g.u" in msg
    assert "shape (3,)" in msg and "shape (2,)" in msg and "shapes differ" in msg
    assert f"scene.yaml:{line_of(tmp_path / 'scene.yaml', 'src.y -> g.u')}" in msg


def test_mismatched_units(scene):
    msg = raises(scene, """
        components:
          pend: {type: pendulum}
          damper: {type: viscous_damper}
        connections:
          - pend.theta -> damper.omega
          - damper.tau -> pend.tau
        """, BuildError)
    assert "cannot connect pend.theta" in msg and "damper.omega" in msg
    assert "[rad]" in msg and "[rad/s]" in msg and "units differ" in msg


def test_mismatched_dtypes(scene):
    msg = raises(scene, """
        components:
          count: {type: test_int_source}
          g: {type: gain}
        connections:
          - count.count -> g.u
        record: [g.y]
        """, BuildError)
    assert "cannot connect count.count" in msg and "g.u" in msg
    assert "int64" in msg and "float64" in msg and "dtypes differ" in msg


def test_structured_to_numeric(scene):
    msg = raises(scene, """
        components:
          w: {type: test_wrench_source}
          g: {type: gain}
        connections:
          - w.w -> g.u
        record: [g.y]
        """, BuildError)
    assert "cannot connect w.w (structured Wrench) -> g.u (numeric" in msg
    assert "one end is structured, the other numeric" in msg


def test_structured_types_that_differ(scene, registry):
    msg = raises(scene, """
        components:
          pend: {type: pendulum}
          f: {type: test_wrench_to_force}
        connections:
          - pend.theta -> f.w
        record: [f.force]
        """, BuildError)
    assert "pend.theta" in msg and "f.w (structured Wrench)" in msg


def test_unconnected_required_input(scene):
    msg = raises(scene, """
        components:
          g: {type: gain, params: {n: 2}}
        record: [g.y]
        """, BuildError)
    assert "required inputs are not connected" in msg
    assert "g.u (gain, numeric shape (2,)" in msg
    assert "source.output -> component.input" in msg


def test_input_wired_twice(scene, tmp_path):
    msg = raises(scene, """
        components:
          a: {type: constant}
          b: {type: constant}
          g: {type: gain}
        connections:
          - a.y -> g.u
          - b.y -> g.u
        record: [g.y]
        """, BuildError)
    path = tmp_path / "scene.yaml"
    assert "input g.u is wired twice: from a.y" in msg and "from b.y" in msg
    assert f"scene.yaml:{line_of(path, 'a.y -> g.u')}" in msg
    assert f"scene.yaml:{line_of(path, 'b.y -> g.u')}" in msg


def test_algebraic_loop_shows_the_cycle_of_ports(scene):
    msg = raises(scene, """
        components:
          a: {type: gain, params: {k: 0.5}}
          b: {type: gain, params: {k: 0.5}}
        connections:
          - a.y -> b.u
          - b.y -> a.u
        record: [a.y]
        """, BuildError)
    assert "algebraic loop" in msg
    cycle = msg.splitlines()[0].split(": ", 1)[1]
    assert cycle in ("a.y -> b.u ; b.y -> a.u", "b.y -> a.u ; a.y -> b.u")


def test_state_only_output_breaks_the_loop(scene):
    """pend.omega -> damper -> pend.tau is a loop of ports but not an algebraic one."""
    s = scene("""
        sim: {duration: 0.01}
        components:
          pend: {type: pendulum}
          damper: {type: viscous_damper}
        connections:
          - pend.omega -> damper.omega
          - damper.tau -> pend.tau
        """)
    assert s.report()["evaluation_order"] == ["pend[theta,omega]", "damper[tau]"]


def test_rate_not_a_whole_number_of_base_steps(scene):
    msg = raises(scene, """
        sim: {dt: 0.001}
        components:
          src: {type: constant}
          zoh: {type: zero_order_hold, rate: 300}
        connections: [src.y -> zoh.u]
        """, BuildError)
    assert "zoh: rate 300 Hz is not an integer number of base steps" in msg
    assert "3.333 steps" in msg and "1000/k Hz" in msg


def test_unknown_component_type_with_close_match(scene, tmp_path):
    msg = raises(scene, """
        components:
          pend: {type: pendulm}
        """, ConfigError)
    assert "unknown component type 'pendulm'" in msg and "did you mean 'pendulum'" in msg
    assert f"scene.yaml:{line_of(tmp_path / 'scene.yaml', 'pend:')}" in msg
    assert "components.pend.type" in msg


def test_unknown_param_key(scene, tmp_path):
    msg = raises(scene, """
        components:
          pend:
            type: pendulum
            params: {lenght: 2.0}
        """, ConfigError)
    assert "components.pend.params.lenght" in msg
    assert "unknown parameter" in msg and "length" in msg
    assert str(tmp_path / "scene.yaml") in msg


def test_bad_param_value_names_key_and_value(scene):
    msg = raises(scene, """
        components:
          pend: {type: pendulum, params: {length: -1.0}}
        """, ConfigError)
    assert "components.pend.params.length" in msg and "greater than 0" in msg and "-1.0" in msg


def test_yaml_key_error_cites_file_line_and_key(scene, tmp_path):
    msg = raises(scene, """
        description: x
        sim:
          duration: 1.0
          dtt: 0.01
        components:
          pend: {type: pendulum}
        """, ConfigError)
    assert msg.startswith(f"{tmp_path / 'scene.yaml'}:4: sim.dtt: unknown key 'dtt'")


def test_bad_sim_value_cites_file_line_and_key(scene, tmp_path):
    msg = raises(scene, """
        sim:
          duration: 1.0
          dt: fast
        components:
          pend: {type: pendulum}
        """, ConfigError)
    assert msg.startswith(f"{tmp_path / 'scene.yaml'}:3: sim.dt: ")
    assert "'fast'" in msg


def test_unknown_top_level_key(scene, tmp_path):
    msg = raises(scene, """
        components:
          pend: {type: pendulum}
        conections:
          - pend.omega -> pend.tau
        """, ConfigError)
    assert msg.startswith(f"{tmp_path / 'scene.yaml'}:3: conections: unknown top-level key 'conections'")
    assert "did you mean 'connections'" in msg


def test_include_of_a_missing_sub_assembly(scene, tmp_path):
    msg = raises(scene, """
        components:
          pend: {type: pendulum}
        include:
          - {assembly: lib/spring-mass-cel}
        """, ConfigError)
    assert "no assembly 'lib/spring-mass-cel'" in msg and "Did you mean: lib/spring-mass-cell" in msg
    assert f"scene.yaml:{line_of(tmp_path / 'scene.yaml', 'spring-mass-cel')}" in msg


def test_bad_include_param(scene, tmp_path):
    msg = raises(scene, """
        include:
          - assembly: lib/spring-mass-cell
            params: {mass: 2.0, stiffness: 5.0}
        """, ConfigError)
    assert "'stiffness' is not a parameter of spring-mass-cell.yaml" in msg
    assert "it declares: mass, k, c, x0" in msg
    assert f"scene.yaml:{line_of(tmp_path / 'scene.yaml', 'stiffness')}" in msg
    assert "include[0].params.stiffness" in msg


def test_connection_naming_a_missing_port(scene, tmp_path):
    msg = raises(scene, """
        components:
          pend: {type: pendulum}
          damper: {type: viscous_damper}
        connections:
          - pend.omegaa -> damper.omega
          - damper.tau -> pend.tau
        """, BuildError)
    assert "'pend.omegaa'" in msg and "pend (pendulum) has no output 'omegaa'; did you mean omega" in msg
    assert f"scene.yaml:{line_of(tmp_path / 'scene.yaml', 'omegaa')}" in msg


def test_connection_naming_a_missing_component(scene):
    msg = raises(scene, """
        components:
          pend: {type: pendulum}
          damper: {type: viscous_damper}
        connections:
          - pendd.omega -> damper.omega
        """, BuildError)
    assert "no component 'pendd'; did you mean pend" in msg


def test_connection_backwards(scene):
    msg = raises(scene, """
        components:
          pend: {type: pendulum}
          damper: {type: viscous_damper}
        connections:
          - damper.omega -> pend.omega
        """, BuildError)
    assert "'omega' is an input of damper" in msg and "output -> input" in msg


def test_template_error_cites_file_and_line(scene, tmp_path):
    msg = raises(scene, """
        parameters: {k: 2.0}
        components:
          g:
            type: gain
            params: {k: "${kk}"}
        """, ConfigError)
    assert f"scene.yaml:{line_of(tmp_path / 'scene.yaml', 'kk')}" in msg
    assert "'${kk}' references 'kk'" in msg


def test_unknown_integrator(scene):
    msg = raises(scene, """
        sim: {integrator: rk5}
        components:
          pend: {type: pendulum}
        """, ConfigError)
    assert "unknown integrator 'rk5'" in msg and "rk4" in msg and "sim.integrator.name" in msg


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
    msg = raises(scene, text, ConfigError, overrides=["sim.dt=-1"])
    assert msg.startswith("--set: sim.dt: ") and "greater than 0" in msg
    msg = raises(scene, text, ConfigError, sim_overrides={"duration": 0.0})
    assert msg.startswith("command line: sim.duration: ")
