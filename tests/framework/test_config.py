"""Unit tests of the configuration layer: templates, located YAML, layering."""

from __future__ import annotations

import pytest

from snakesim.framework.errors import ConfigError
from snakesim.framework.expressions import evaluate, substitute
from snakesim.framework.layering import deep_merge, parse_set, set_override
from snakesim.framework.yaml_source import LocatedDict, load_yaml, load_yaml_text


# -- expressions ------------------------------------------------------------------

SCOPE = {"i": 2, "n": 7, "k": 2.5, "robot": {"modules": 10, "name": "eels"}}


@pytest.mark.parametrize("text, value", [
    ("${i+1}", 3),
    ("${n - 1}", 6),
    ("${(i + 1) * 2}", 6),
    ("${n // 2}", 3),
    ("${n % 4}", 3),
    ("${n / 2}", 3.5),
    ("${-i}", -2),
    ("${robot.modules}", 10),
    ("${robot.modules * 2 + i}", 22),
    ("${k}", 2.5),
])
def test_whole_string_template_keeps_the_type(text, value):
    out = substitute(text, SCOPE)
    assert out == value and type(out) is type(value)


def test_templates_inside_longer_strings_are_formatted():
    assert substitute("cell${i+1}/spring.x_a", SCOPE) == "cell3/spring.x_a"
    assert substitute("${robot.name}-${robot.modules}", SCOPE) == "eels-10"
    assert substitute("seg${n / 7}", SCOPE) == "seg1"          # integral floats print as ints
    assert substitute("no template", SCOPE) == "no template"


def test_substitute_walks_mappings_and_lists_and_keeps_positions():
    d = LocatedDict({"m${i}": {"x0": "${i * 1.5}"}, "list": ["${n}", "a${i}"]})
    d.file, d.line = "f.yaml", 3
    d.pos = {"m${i}": ("f.yaml", 4), "list": ("f.yaml", 5)}
    out = substitute(d, SCOPE)
    assert out == {"m2": {"x0": 3.0}, "list": [7, "a2"]}
    assert out.where("m2") == "f.yaml:4"


@pytest.mark.parametrize("text", [
    "${__import__('os')}",
    "${open('x')}",
    "${len(robot)}",
    "${i ** 2}",
    "${[1, 2]}",
    "${i if n else k}",
    "${lambda: 1}",
    "${'abc'}",
])
def test_disallowed_syntax_is_rejected_without_eval(text):
    with pytest.raises(ConfigError) as e:
        substitute(text, SCOPE)
    assert text in str(e.value)
    assert "only parameter names, numbers" in str(e.value)


def test_unknown_parameter_names_the_template_and_the_known_ones():
    with pytest.raises(ConfigError) as e:
        substitute("${robot.modulez}", SCOPE)
    msg = str(e.value)
    assert "'${robot.modulez}' references 'robot.modulez'" in msg
    assert "i, k, n, robot" in msg
    with pytest.raises(ConfigError, match="not a parameter"):
        substitute("${__class__}", SCOPE)      # attribute names are parameter paths, never Python attributes


def test_syntax_error_in_template():
    with pytest.raises(ConfigError, match=r"'\$\{i \+\}' is not a valid expression"):
        evaluate("i +", SCOPE)


@pytest.mark.parametrize("text", ["${n // 0}", "${n % 0}", "${k / 0}"])
def test_division_by_zero_is_a_config_error(text):
    with pytest.raises(ConfigError, match="division by zero"):
        substitute(text, SCOPE)


@pytest.mark.parametrize("text", ["${robot.name + 1}", "${robot.name * 100000}", "${robot + 1}", "${-robot.name}"])
def test_arithmetic_on_non_numbers_is_a_config_error(text):
    with pytest.raises(ConfigError, match="numbers"):
        substitute(text, SCOPE)


# -- yaml_source ---------------------------------------------------------------------

def test_yaml_positions_are_kept():
    d = load_yaml_text("a: 1\nb:\n  c: [1, 2]\n  d:\n    - x\n    - y\n", "s.yaml")
    assert d.where("a") == "s.yaml:1"
    assert d["b"].where("c") == "s.yaml:3"
    assert d["b"]["d"].where(1) == "s.yaml:6"


def test_duplicate_key_error_names_the_line_of_both():
    text = "sim:\n  dt: 0.001\n  duration: 1\n  dt: 0.002\n"
    with pytest.raises(ConfigError) as e:
        load_yaml_text(text, "scene.yaml")
    assert str(e.value).startswith("scene.yaml:4: duplicate key 'dt' (first at line 2)")


def test_merge_keys_are_not_duplicates():
    text = "base: &b {a: 1, c: 3}\nx:\n  <<: *b\n  a: 2\n"
    d = load_yaml_text(text, "m.yaml")
    assert d["x"] == {"a": 2, "c": 3}        # explicit keys override merged ones (YAML merge semantics)
    with pytest.raises(ConfigError, match="m.yaml:5: duplicate key 'a'"):
        load_yaml_text(text + "  a: 4\n", "m.yaml")


def test_invalid_yaml_error_has_file_and_line(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text("components:\n  pend: {type: pendulum\n  other: 1\n")   # '}' missing on line 2
    with pytest.raises(ConfigError) as e:
        load_yaml(p)
    # the parser notices at line 3, where a ':' comes instead of ',' or '}'
    assert str(e.value).startswith(f"{p}:3: invalid YAML: expected ',' or '}}'")
    p.write_text("a: 1\n  b: 2\n")
    with pytest.raises(ConfigError, match=f"^{p}:2: invalid YAML: mapping values are not allowed"):
        load_yaml(p)


def test_missing_yaml_file(tmp_path):
    with pytest.raises(ConfigError, match="file not found"):
        load_yaml(tmp_path / "nope.yaml")


def test_unsafe_tags_are_refused():
    with pytest.raises(ConfigError, match="invalid YAML"):
        load_yaml_text("a: !!python/object/apply:os.system ['true']\n", "evil.yaml")


# -- layering ---------------------------------------------------------------------------

def test_deep_merge_merges_mappings_and_replaces_lists():
    base = load_yaml_text("sim: {dt: 0.001, duration: 5}\nrecord: [a.y, b.y]\nc: {p: {x: 1, y: 2}}\n", "base.yaml")
    over = load_yaml_text("sim: {dt: 0.002}\nrecord: [c.y]\nc: {p: {y: 3}}\n", "over.yaml")
    m = deep_merge(base, over)
    assert m == {"sim": {"dt": 0.002, "duration": 5}, "record": ["c.y"], "c": {"p": {"x": 1, "y": 3}}}
    assert m["sim"].where("dt") == "over.yaml:1"
    assert m["sim"].where("duration") == "base.yaml:1"
    assert base["sim"]["dt"] == 0.001                      # inputs untouched


def test_parse_set_values_are_yaml():
    assert parse_set("sim.dt=0.002") == (["sim", "dt"], 0.002)
    assert parse_set("record=[a.y, b.y]") == (["record"], ["a.y", "b.y"])
    assert parse_set("components.x.params.name=eels") == (["components", "x", "params", "name"], "eels")
    assert parse_set("a.b=") == (["a", "b"], "")
    assert parse_set("a=x=y") == (["a"], "x=y")


@pytest.mark.parametrize("item, match", [
    ("sim.dt", "needs the form key.path=value"),
    ("sim..dt=1", "empty key"),
    ("=1", "empty key"),
    ("sim.dt=[1, 2", "not valid YAML"),
])
def test_parse_set_errors(item, match):
    with pytest.raises(ConfigError, match=match) as e:
        parse_set(item)
    assert e.value.where == "--set"


def test_set_override_parameter_shorthand():
    params = {"damping": 0.05, "robot": {"modules": 10}}
    assert set_override("damping=0.1", params) == {"parameters": {"damping": 0.1}}
    assert set_override("robot.modules=4", params) == {"parameters": {"robot": {"modules": 4}}}
    assert set_override("sim.dt=0.01", params) == {"sim": {"dt": 0.01}}


def test_set_override_unknown_key_lists_close_matches():
    with pytest.raises(ConfigError) as e:
        set_override("dampin=0.1", {"damping": 0.05})
    msg = str(e.value)
    assert "'dampin' is neither a top-level key" in msg
    assert "did you mean damping" in msg
    with pytest.raises(ConfigError, match="did you mean sim"):
        set_override("simm.dt=0.1", {})


def test_exponent_floats_are_floats_as_in_yaml_1_2():
    d = load_yaml_text("k: 1e6\ndt: 1e-4\nneg: -2.5E+3\nname: e5\nver: v1e3\nn: 12\n", "f.yaml")
    assert d == {"k": 1e6, "dt": 1e-4, "neg": -2500.0, "name": "e5", "ver": "v1e3", "n": 12}
    assert type(d["k"]) is float and type(d["n"]) is int
    assert parse_set("k=1e6") == (["k"], 1e6)
    assert substitute("${k * 2}", d) == 2e6


def test_merge_layer_integrator_shorthand():
    from snakesim.framework.layering import merge_layer

    base = load_yaml_text("sim: {dt: 0.01, integrator: dopri5}\n", "a.yaml")
    m = merge_layer(base, load_yaml_text("sim: {integrator: {params: {rtol: 1e-8}}}\n", "b.yaml"))
    assert m["sim"] == {"dt": 0.01, "integrator": {"name": "dopri5", "params": {"rtol": 1e-8}}}
    base = load_yaml_text("sim: {integrator: {name: rk4, params: {substeps: 2}}}\n", "a.yaml")
    m = merge_layer(base, load_yaml_text("sim: {integrator: {name: dopri5, params: {rtol: 1e-8}}}\n", "b.yaml"))
    assert m["sim"]["integrator"] == {"name": "dopri5", "params": {"rtol": 1e-8}}
    m = merge_layer(base, load_yaml_text("sim: {integrator: {name: rk4, params: {}}}\n", "b.yaml"))
    assert m["sim"]["integrator"] == {"name": "rk4", "params": {"substeps": 2}}
    m = merge_layer(base, load_yaml_text("sim: {integrator: rosenbrock2}\n", "b.yaml"))
    assert m["sim"]["integrator"] == "rosenbrock2"
    assert base["sim"]["integrator"] == {"name": "rk4", "params": {"substeps": 2}}   # input untouched


def test_parameter_typo_in_a_later_layer_is_an_error(tmp_path):
    from snakesim.framework.errors import ConfigError
    from snakesim.framework.registry import default_registry
    from snakesim.framework.session import load_session

    cfg = tmp_path / "c.yaml"
    cfg.write_text("parameters:\n  dampin: 0.3\n")
    with pytest.raises(ConfigError) as e:
        load_session("pendulum", config_files=[cfg], registry=default_registry())
    msg = str(e.value)
    assert f"{cfg}:2" in msg and "'dampin' is not a parameter of pendulum.yaml" in msg and "damping" in msg
    with pytest.raises(ConfigError, match="'dampin' is not a parameter"):
        load_session("pendulum", overrides=["parameters.dampin=0.3"], registry=default_registry())


@pytest.mark.parametrize("template, scope, expected", [
    ("module_${n - 1:02d}", {"n": 12}, "module_11"),
    ("module_${n - 1:02d}", {"n": 4}, "module_03"),
    ("${x:.2f}", {"x": 1.23456}, "1.23"),
])
def test_template_format_spec_pads_systematic_names(template, scope, expected):
    from snakesim.framework.expressions import substitute

    assert substitute(template, scope) == expected


def test_template_format_spec_that_does_not_apply_is_an_error():
    from snakesim.framework.errors import ConfigError
    from snakesim.framework.expressions import substitute

    with pytest.raises(ConfigError, match="format '02d' does not apply to 1.5"):
        substitute("m_${x:02d}", {"x": 1.5})
