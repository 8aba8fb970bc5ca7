"""Issue 17: a property-based fuzz of the assembly loader and of ``--set``: whatever the input, it
ends in a clear SnakesimError (ConfigError, BuildError, ...) or a built session, never another
exception type (a traceback). Bounded: 200 examples per property, a few seconds each."""

from __future__ import annotations

import string

import pytest

hypothesis = pytest.importorskip("hypothesis")   # in the test extra (pyproject.toml)
from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402

from snakesim.framework.errors import SnakesimError  # noqa: E402
from snakesim.framework.session import load_session  # noqa: E402
from snakesim.framework.yaml_source import dump_yaml  # noqa: E402

BASE = """\
parameters: {k: 2.0, n: 1}
sim: {duration: 0.01, dt: 0.001}
components:
  src: {type: constant, params: {value: 1.0, n: "${n}"}}
  g: {type: gain, params: {k: "${k}", n: "${n}"}}
  zoh: {type: zero_order_hold, rate: 100}
connections: [src.y -> g.u, g.y -> zoh.u]
record: [zoh.y]
"""

FUZZ = settings(max_examples=200, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

scalars = st.one_of(st.none(), st.booleans(), st.integers(-10 ** 12, 10 ** 12),
                    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=20),
                    st.sampled_from(["${k}", "${n+1}", "${k*1e308*10}", "${i:05d}", "${n:0999d}", "${nope}",
                                     "${__import__}", "${k/0}", "a.y -> b.u", "src.y -> g.u", "rk4", "dopri5"]))
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                      st.dictionaries(st.text(max_size=8), inner, max_size=4)),
                      max_leaves=12)
keys = st.sampled_from(["description", "parameters", "sim", "include", "components", "connections", "record",
                        "stop", "bogus"])
sub_keys = st.sampled_from(["duration", "dt", "integrator", "type", "params", "rate", "uses", "k", "n", "value",
                            "assembly", "repeat", "as", "connect", "signal", "above", "src", "g", "zoh", "name"])


def _check(make):
    try:
        make()
    except SnakesimError:
        pass


@FUZZ
@given(top=st.dictionaries(keys, st.one_of(values, st.dictionaries(sub_keys, values, max_size=4)), max_size=5))
def test_any_assembly_mapping_is_an_error_or_a_build(top, registry, tmp_path_factory):
    path = tmp_path_factory.mktemp("fuzz") / "scene.yaml"
    path.write_text(dump_yaml(top))
    _check(lambda: load_session(path, registry=registry))


@FUZZ
@given(edit=st.tuples(st.integers(0, len(BASE)), st.integers(0, 40),
                      st.text(alphabet=string.printable + "\x00\x85\ufeff&*!|>%@`{}[]-:", max_size=30)))
def test_any_edit_of_a_good_assembly_is_an_error_or_a_build(edit, registry, tmp_path_factory):
    at, cut, insert = edit
    path = tmp_path_factory.mktemp("fuzz") / "scene.yaml"
    path.write_bytes((BASE[:at] + insert + BASE[at + cut:]).encode("utf-8", "surrogatepass"))
    _check(lambda: load_session(path, registry=registry))


@FUZZ
@given(raw=st.binary(max_size=200))
def test_any_bytes_are_an_error_or_a_build(raw, registry, tmp_path_factory):
    path = tmp_path_factory.mktemp("fuzz") / "scene.yaml"
    path.write_bytes(raw)
    _check(lambda: load_session(path, registry=registry))


set_keys = st.sampled_from(["k", "n", "sim", "sim.dt", "sim.duration", "sim.integrator", "sim.integrator.params.rtol",
                            "sim.integrator.params.substeps", "sim.integrator.name", "components.g.params.k",
                            "components.g.params.n", "components.g", "components.new.type", "connections", "record",
                            "stop", "parameters", "include", "components.src.params.value", "nope", "", ".", "a..b"])
set_values = st.one_of(st.text(max_size=30), st.sampled_from(
    [".inf", "-.inf", ".nan", "true", "1e400", "1e-400", "[1, 2]", "{a: 1}", "~", "5", "-1", "0", "'x'", "[",
     "&a [*a]", "${k}", "dopri5", "rk4", "!!python/object:os.system", "1" * 5000]))


@FUZZ
@given(sets=st.lists(st.tuples(set_keys, set_values), min_size=1, max_size=3),
       flags=st.fixed_dictionaries({}, optional={"integrator": st.sampled_from(["rk4", "dopri5", "nope"]),
                                                 "duration": st.floats(allow_nan=True, allow_infinity=True),
                                                 "dt": st.floats(allow_nan=True, allow_infinity=True)}))
def test_any_set_override_is_an_error_or_a_build(sets, flags, registry, tmp_path_factory):
    path = tmp_path_factory.mktemp("fuzz") / "scene.yaml"
    path.write_text(BASE)
    overrides = [f"{k}={v}" for k, v in sets]
    _check(lambda: load_session(path, registry=registry, overrides=overrides, sim_overrides=flags))
