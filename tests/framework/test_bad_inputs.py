"""Issue 17: every bad input is a clear error at the boundary that should catch it.

Each class of bad input has a test here, asserting the message names the file, key or value
and says what would be valid: non-finite and boolean parameters (the Params base), settings
silently dropped or coerced (layering, top-level key types, empty assemblies), the YAML
boundary (encodings, binary files, nesting, alias bombs, repeats, template sizes) and plugins.
"""

from __future__ import annotations

import importlib.metadata
import math

import pytest
from pydantic import BaseModel, Field, ValidationError

from snakesim.framework import Params
from snakesim.framework import expressions, registry as registry_mod
from snakesim.framework.errors import ConfigError, RegistryError
from snakesim.framework.yaml_source import MAX_DEPTH, MAX_NODES, load_yaml

BASE = """
sim: {duration: 0.01, dt: 0.001}
components:
  src: {type: constant, params: {value: 1.0}}
  g: {type: gain}
connections: [src.y -> g.u]
record: [g.y]
"""


def _error(make, *a, **kw) -> str:
    with pytest.raises(ConfigError) as e:
        make(*a, **kw)
    return str(e.value)


# -- 1. non-finite parameters: the Params base -------------------------------------------------

@pytest.mark.parametrize("override, expect", [
    ("components.g.params.k=.inf", "components.g.params.k: Input should be a finite number (got inf)"),
    ("components.g.params.k=-.inf", "components.g.params.k: Input should be a finite number (got -inf)"),
    ("components.g.params.k=.nan", "components.g.params.k: Input should be a finite number (got nan)"),
    ("components.src.params.value=[1.0, .nan]", "components.src.params.value"),
    ("sim.duration=.inf", "sim.duration: Input should be a finite number"),
    ("sim.integrator.params.rtol=.nan", "finite number"),
])
def test_non_finite_parameters_are_refused_naming_key_and_value(scene, override, expect):
    extra = ["sim.integrator=dopri5"] if "rtol" in override else []
    msg = _error(scene, BASE, overrides=extra + [override])
    assert expect in msg


def test_params_base_refuses_non_finite_in_nested_models_tuples_and_dicts():
    class Inner(Params):
        a: float = 1.0

    class P(Params):
        t: tuple[float, float] = (0.0, 0.0)
        d: dict[str, float] = {}
        inner: Inner = Inner()
        opt: float | None = None
        unbounded: float = Field(1.0, allow_inf_nan=True)      # the explicit opt-in

    for bad in ({"t": (1.0, math.nan)}, {"d": {"x": math.inf}}, {"inner": {"a": -math.inf}}, {"opt": math.inf}):
        with pytest.raises(ValidationError, match="finite number"):
            P(**bad)
    assert P(unbounded=math.inf).unbounded == math.inf
    assert P(opt=None).opt is None


def _models_in(annotation, out):
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        out.append(annotation)
        return
    for arg in getattr(annotation, "__args__", ()) or ():
        _models_in(arg, out)


def test_every_registered_parameter_model_refuses_non_finite(registry):
    """The root fix holds for every component and integrator, nested models included: only the
    material (whose own validators check finiteness, naming the material) opts out model-wide."""
    opted_out = {"snakesim.components.materials.Material"}
    seen, todo = set(), [c.Params for c in registry.components.values()] + \
        [c.Params for c in registry.integrators.values()]
    while todo:
        model = todo.pop()
        if model in seen:
            continue
        seen.add(model)
        for f in model.model_fields.values():
            _models_in(f.annotation, todo)
        name = f"{model.__module__}.{model.__qualname__}"
        if name not in opted_out:
            assert model.model_config.get("allow_inf_nan") is False, name
    assert len(seen) > 40


def test_material_non_finite_is_refused_naming_the_material():
    from snakesim.components.materials import Material

    with pytest.raises(ValidationError, match="material 'ice': k = inf is not a finite number"):
        Material(name="ice", k=math.inf)
    with pytest.raises(ValidationError, match="texture_size"):
        Material(name="ice", texture_size=math.inf)


# -- 3. settings silently dropped or coerced ----------------------------------------------------

@pytest.mark.parametrize("override, key", [
    ("components.g.params.n=true", "components.g.params.n"),
    ("components.src.params.n=false", "components.src.params.n"),
    ("components.g.params.k=true", "components.g.params.k"),
])
def test_booleans_do_not_pass_as_numbers(scene, override, key):
    msg = _error(scene, BASE, overrides=[override])
    assert key in msg and "is a boolean; a number is expected here" in msg


def test_a_boolean_inside_a_list_of_numbers_is_refused():
    class P(Params):
        xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
        flag: bool = False

    with pytest.raises(ValidationError, match="item 2 is true, a boolean"):
        P(xyz=(0.0, 1.0, True))
    assert P(flag=True).flag is True


@pytest.mark.parametrize("overrides, sim_overrides", [
    (["sim.integrator.params.rtol=1e-3"], {"integrator": "dopri5"}),          # --set, then --integrator
    (["sim.integrator.params.rtol=1e-3", "sim.integrator=dopri5"], None),     # params first, name later
    (["sim.integrator=dopri5", "sim.integrator.params.rtol=1e-3"], None),
    (["sim.integrator.name=dopri5", "sim.integrator.params.rtol=1e-3"], {"integrator": "dopri5"}),
])
def test_integrator_params_set_on_the_command_line_are_kept(scene, overrides, sim_overrides):
    s = scene(BASE, overrides=overrides, sim_overrides=sim_overrides)
    assert s.integrator.name == "dopri5"
    assert s.integrator.p.rtol == 1e-3


def test_integrator_params_that_do_not_apply_are_an_error(scene):
    msg = _error(scene, BASE, overrides=["sim.integrator.params.rtol=1e-3"])    # rk4 has no rtol
    assert "sim.integrator.params" in msg and "rtol" in msg


@pytest.mark.parametrize("replace, key, what", [
    (("sim: {duration: 0.01, dt: 0.001}", "sim: 5"), "sim", "must be a mapping, got a number: '5'"),
    (("connections: [src.y -> g.u]", "connections: 5"), "connections", "must be a list"),
    (("record: [g.y]", "record: src.y"), "record", "must be a list, got a string: 'src.y'"),
    (("record: [g.y]", "stop: {signal: g.y}"), "stop", "must be a list"),
    (("record: [g.y]", "description: [1]"), "description", "must be a string"),
])
def test_a_top_level_key_of_the_wrong_type_is_an_error_naming_it(scene, replace, key, what):
    msg = _error(scene, BASE.replace(*replace))
    assert f"scene.yaml:" in msg and f"{key}: '{key}' {what}" in msg


def test_wrong_type_from_set_is_an_error_too(scene):
    assert "--set: sim: 'sim' must be a mapping, got a number: '5'" in _error(scene, BASE, overrides=["sim=5"])


@pytest.mark.parametrize("text", ["components: {}\n", "sim: {duration: 1}\n", "description: nothing here\n"])
def test_an_assembly_without_components_is_refused(scene, text):
    msg = _error(scene, text)
    assert "scene.yaml: components: the assembly has no components: nothing to simulate" in msg


# -- 4. the YAML boundary -------------------------------------------------------------------------

def test_non_utf8_and_binary_files_name_the_file_and_byte_offset(tmp_path):
    latin = tmp_path / "latin.yaml"
    latin.write_bytes("description: caf\xe9\n".encode("latin-1"))
    msg = _error(load_yaml, latin)
    assert str(latin) in msg and "not UTF-8 text: byte 0xe9 at byte offset 16" in msg

    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"sim: {duration: 1}\n\x00\x01\x02")
    msg = _error(load_yaml, binary)
    assert f"{binary}:2: character U+0000 at byte offset 19 is not allowed" in msg

    png = tmp_path / "image.yaml"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)))
    assert "not UTF-8 text" in _error(load_yaml, png)


def test_a_binary_include_or_config_file_names_that_file(scene, write_yaml, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_bytes(b"\xff\xfe")
    msg = _error(scene, BASE, config_files=[bad])
    assert f"{bad}: not UTF-8 text" in msg
    msg = _error(scene, BASE + f"include: [{{assembly: {bad}}}]\n")
    assert f"{bad}: not UTF-8 text" in msg


@pytest.mark.parametrize("content, got", [("5\n", "int"), ("- a\n- b\n", "LocatedList"), ("just text\n", "str")])
def test_an_include_that_is_not_a_mapping_is_an_error(scene, tmp_path, content, got):
    inc = tmp_path / "part.yaml"
    inc.write_text(content)
    msg = _error(scene, BASE + f"include: [{{assembly: {inc}}}]\n")
    assert f"include[0].assembly: included assembly {inc} is not a YAML mapping (got {got})" in msg


def test_deep_nesting_is_refused_naming_the_limit(tmp_path):
    for text in ("a: " + "[" * 5000 + "]" * 5000, "a:\n" + "".join("  " * i + f"k{i}:\n" for i in range(1, 200))):
        p = tmp_path / "deep.yaml"
        p.write_text(text)
        msg = _error(load_yaml, p)
        assert f"YAML nests more than {MAX_DEPTH} levels deep (the limit)" in msg and str(p) in msg
    ok = tmp_path / "ok.yaml"
    ok.write_text("a: " + "[" * 30 + "]" * 30)
    load_yaml(ok)


def test_alias_bombs_are_refused_before_they_expand(tmp_path):
    lines = ["a: &a [x, x, x, x, x, x, x, x, x, x]"]
    for n in range(1, 9):
        prev, cur = chr(96 + n), chr(97 + n)
        lines.append(f"{cur}: &{cur} [" + ", ".join([f"*{prev}"] * 10) + "]")
    p = tmp_path / "bomb.yaml"
    p.write_text("\n".join(lines))
    msg = _error(load_yaml, p)
    assert f"YAML expands to more than {MAX_NODES:,} nodes (the limit" in msg
    small = tmp_path / "anchors.yaml"                 # ordinary anchors and merge keys still work
    small.write_text("base: &b {k: 1}\nother: {<<: *b, j: 2}\nlist: [*b, *b]\n")
    assert load_yaml(small)["other"] == {"k": 1, "j": 2}


def test_a_recursive_alias_is_refused(tmp_path):
    p = tmp_path / "loop.yaml"
    p.write_text("a: &a [1, *a]\n")
    assert "recursive YAML alias" in _error(load_yaml, p)


@pytest.mark.parametrize("repeat, expect", [
    ("100000000", "include[0].repeat: Input should be less than or equal to 10000 (got 100000000)"),
    ("true", "include[0].repeat: Input should be a valid integer (got True)"),
    ("-1", "include[0].repeat: Input should be greater than or equal to 0"),
])
def test_include_repeat_is_bounded(scene, tmp_path, repeat, expect):
    part = tmp_path / "part.yaml"
    part.write_text("components: {c: {type: constant}}\n")
    assert expect in _error(scene, BASE + f"include: [{{assembly: {part}, repeat: {repeat}}}]\n")


@pytest.mark.parametrize("repeat", ["100000000", "true", "-2"])
def test_connection_repeat_is_bounded(scene, repeat):
    text = BASE.replace("connections: [src.y -> g.u]", f"connections: [{{connect: 'src.y -> g.u', repeat: {repeat}}}]")
    msg = _error(scene, text)
    assert "connections[0].repeat: repeat must be an integer from 0 to 10000 (the limit)" in msg


@pytest.mark.parametrize("template, scope, expect", [
    ("${n:01000000000d}", {"n": 1}, f"is wider than {expressions.MAX_FORMAT_WIDTH} characters (the limit)"),
    ("x${s}" * 5, {"s": "y" * 30_000}, f"formats into more than {expressions.MAX_STRING:,} characters (the limit)"),
    ("${n*n*n*n*n*n*n*n*n*n}", {"n": 10 ** 10}, f"more than {expressions.MAX_INT_DIGITS} digits (the limit)"),
    ("${" + "1+" * 400 + "1}", {}, f"longer than {expressions.MAX_EXPRESSION} characters (the limit)"),
])
def test_templates_are_bounded(template, scope, expect):
    assert expect in _error(expressions.substitute, template, scope)


def test_a_template_in_an_assembly_that_formats_a_huge_string_names_file_and_key(scene):
    text = BASE.replace("components:", "parameters: {n: 1}\ncomponents:\n"
                                       "  big: {type: constant, params: {value: '${n:0999999999d}'}}")
    msg = _error(scene, text)
    assert "scene.yaml:" in msg and "wider than 100 characters (the limit)" in msg


# -- 5. plugins -------------------------------------------------------------------------------------

class _FakeDist:
    def __init__(self, name):
        self.name = name


class _FakeEntryPoint:
    group = registry_mod.ENTRY_POINT_GROUP

    def __init__(self, name, obj=None, error=None, dist="thirdparty"):
        self.name, self.value, self.dist = name, f"{dist}.module:{name}", _FakeDist(dist)
        self._obj, self._error = obj, error

    def load(self):
        if self._error is not None:
            raise self._error
        return self._obj


def _with_entry_points(monkeypatch, *extra):
    real = list(importlib.metadata.entry_points(group=registry_mod.ENTRY_POINT_GROUP))
    monkeypatch.setattr(registry_mod, "entry_points", lambda group: real + list(extra))
    monkeypatch.setattr(registry_mod, "BROKEN_PLUGINS", {})


def _plugin_registering(type_name: str, tag: str):
    from snakesim.framework import Component
    from snakesim.framework.hookspecs import hookimpl

    cls = type(f"Clash{tag}", (Component,), {"type_name": "", "__module__": f"plugin_{tag}"})

    class Plugin:
        @staticmethod
        @hookimpl
        def snakesim_register_components(registry):
            registry.add_component(cls, name=type_name)

    return Plugin()


def test_a_plugin_that_fails_to_import_is_reported_and_the_rest_load(monkeypatch, capsys):
    _with_entry_points(monkeypatch, _FakeEntryPoint("broken", error=ImportError("No module named 'nothere'")))
    reg = registry_mod.build_registry()
    err = capsys.readouterr().err
    assert "snakesim: warning: plugin 'thirdparty:broken' failed to load (thirdparty.module:broken)" in err
    assert "No module named 'nothere'" in err and "going on without it" in err
    assert "gain" in reg.components and "rk4" in reg.integrators


def test_a_plugin_that_raises_while_registering_is_reported(monkeypatch, capsys):
    from snakesim.framework.hookspecs import hookimpl

    class Raising:
        @staticmethod
        @hookimpl
        def snakesim_register_components(registry):
            raise RuntimeError("boom")

    _with_entry_points(monkeypatch, _FakeEntryPoint("raising", obj=Raising()))
    reg = registry_mod.build_registry()
    assert "plugin 'thirdparty:raising' failed in snakesim_register_components: RuntimeError: boom" in \
        capsys.readouterr().err
    assert "gain" in reg.components


def test_a_name_two_plugins_register_is_an_error_only_where_used(monkeypatch):
    _with_entry_points(monkeypatch, _FakeEntryPoint("one", obj=_plugin_registering("twin", "a"), dist="pkg-a"),
                       _FakeEntryPoint("two", obj=_plugin_registering("twin", "b"), dist="pkg-b"))
    reg = registry_mod.build_registry()
    assert "gain" in reg.components and "twin" not in reg.components        # the rest is usable
    with pytest.raises(RegistryError) as e:
        reg.component("twin")
    msg = str(e.value)
    assert "component type 'twin' is registered by more than one plugin" in msg
    assert "pkg-a:one: plugin_a.Clasha" in msg and "pkg-b:two: plugin_b.Clashb" in msg


def test_cli_help_survives_a_broken_plugin(monkeypatch):
    from click.testing import CliRunner

    from snakesim.framework import cli as cli_mod

    _with_entry_points(monkeypatch, _FakeEntryPoint("broken", error=SyntaxError("invalid syntax")))
    result = CliRunner().invoke(cli_mod.cli, ["--help"])
    assert result.exit_code == 0, result.output
    assert "Usage" in result.output
