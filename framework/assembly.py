"""Assemblies: YAML scenes and sub-assemblies, expanded into one flat configuration.

An assembly file has these top-level keys (all optional)::

    description: text
    parameters:  {name: default, ...}         # referenced as ${name} below
    sim:         {duration, dt, integrator, record_rate, realtime}
    include:     [{assembly: NAME, as: PREFIX, repeat: N, params: {...}}]
    components:  {name: {type: TYPE, params: {...}, rate: HZ, uses: {slot: PROVIDER}}}
    connections: ["a.y -> b.u", "a.y -> b.u, c.u", {connect: "...", repeat: N}]
    record:      ["a.y", ...]
    stop:        [{signal: a.y, index: 0, above: 1.0, reason: "...", outcome: failure}]

A ``stop:`` entry ends the run when its bound holds; ``outcome`` says what that means:
``failure`` (the default: the robot fell, contact blew up) or ``success`` (the run reached its goal);
see :mod:`.outcomes` for the summary's ``outcome`` and the exit codes.

Included components are named ``PREFIX/name``; inside a repeated include and a
repeated connection, ``${i}`` is the repetition index (0-based). Expansion
substitutes templates (:mod:`.expressions`) and returns a :class:`Resolved`
configuration that has no includes left: the form saved as ``config.yaml``,
which loads and runs again as it is.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from .errors import ConfigError
from .expressions import substitute
from .layering import TOP_KEYS, deep_merge, merge_layer, set_override
from .paths import locate_strings
from .validation_errors import config_error, where_in
from .yaml_source import LocatedDict, load_yaml


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


#: most repetitions of one include or connection (``repeat:``)
MAX_REPEAT = 10_000
#: the type each top-level key must have (None is the key's default)
_TOP_TYPES = {"description": (str, "a string"), "parameters": (dict, "a mapping"), "sim": (dict, "a mapping"),
              "include": (list, "a list"), "components": (dict, "a mapping"), "connections": (list, "a list"),
              "record": (list, "a list"), "stop": (list, "a list")}


class IntegratorSpec(_Strict):
    name: str = "rk4"
    params: dict = Field(default_factory=dict)


class SimSpec(_Strict):
    duration: float = Field(10.0, gt=0, description="simulated time, s")
    dt: float = Field(1e-3, gt=0, description="base step: recording, discrete rates and ZOH, s")
    integrator: IntegratorSpec = Field(default_factory=IntegratorSpec)
    record_rate: float | None = Field(None, gt=0, description="Hz; default every base step")
    realtime: bool = False
    t0: float = 0.0

    @field_validator("integrator", mode="before")
    @classmethod
    def _name_only(cls, v):
        return {"name": v} if isinstance(v, str) else v


class ComponentSpec(_Strict):
    type: str
    params: dict = Field(default_factory=dict)
    rate: float | None = Field(None, gt=0, description="Hz, for discrete components")
    uses: dict[str, str] = Field(default_factory=dict, description="resource slot -> providing component; "
                                                                   "needed only when several provide one")


class StopSpec(_Strict):
    signal: str
    index: int | list[int] | None = None
    above: float | None = None
    below: float | None = None
    abs_above: float | None = None
    reason: str | None = None
    outcome: Literal["success", "failure"] = Field(
        "failure", description="what the stop means: the run failed (default) or reached its goal")


class IncludeSpec(_Strict):
    assembly: str
    as_: str | None = Field(None, alias="as")
    repeat: int = Field(1, ge=0, le=MAX_REPEAT, strict=True)
    params: dict = Field(default_factory=dict)


#: the top-level keys whose mapping has a fixed set of keys (listed when the key is not a mapping)
_TOP_SCHEMAS = {"sim": SimSpec}


@dataclass
class Resolved:
    """A fully expanded configuration, ready to build."""

    sim: SimSpec
    parameters: dict
    components: dict[str, ComponentSpec]
    connections: list[tuple[str, str, str | None]]   # (source, target, where)
    record: list[tuple[str, str | None]]
    stop: list[tuple[StopSpec, str | None]]
    description: str = ""
    where: dict[str, str | None] = field(default_factory=dict)  # component -> file:line
    source: str | None = None

    def to_dict(self, full_params: dict | None = None) -> dict:
        comps = {}
        for name, spec in self.components.items():
            d = {"type": spec.type, "params": (full_params or {}).get(name, spec.params)}
            if spec.rate is not None:
                d["rate"] = spec.rate
            if spec.uses:
                d["uses"] = dict(spec.uses)
            comps[name] = d
        return {
            "description": self.description,
            "sim": self.sim.model_dump(mode="json"),
            "parameters": self.parameters,
            "include": [],
            "components": comps,
            "connections": [f"{s} -> {t}" for s, t, _ in self.connections],
            "record": [r for r, _ in self.record],
            "stop": [s.model_dump(mode="json", exclude_none=True) for s, _ in self.stop],
        }


# -- locating assembly files ---------------------------------------------------

def _search_dirs(extra_dirs) -> list[Path]:
    return [Path(str(d)) for d in extra_dirs]


def available_assemblies(search_path) -> list[str]:
    names = set()
    for d in _search_dirs(search_path):
        if d.is_dir():
            names.update(p.stem for p in d.glob("*.yaml"))
    return sorted(names)


def find_assembly(ref: str, search_path, relative_to: Path | None = None) -> Path:
    """A path, or a name looked up next to the including file, then on the search path."""
    p = Path(ref)
    if p.suffix in (".yaml", ".yml") and p.is_file():
        return p
    candidates = []
    bases = ([relative_to] if relative_to else []) + _search_dirs(search_path)
    for base in bases:
        for name in (ref, ref + ".yaml"):
            candidates.append(base / name)
    for c in candidates:
        if c.is_file():
            return c
    names = available_assemblies(search_path)
    # sub-assemblies (lib/...) are matched too, though not listed as scenes
    known = set(names)
    for base in bases:
        if base.is_dir():
            known.update(str(p.relative_to(base).with_suffix("")) for p in base.glob("*/*.yaml"))
    close = difflib.get_close_matches(ref, sorted(known), n=4, cutoff=0.4)
    hint = f" Did you mean: {', '.join(close)}?" if close else ""
    raise ConfigError(f"no assembly '{ref}': not a file, and not a scene name ({', '.join(names) or 'none found'}).{hint}")


# -- validation helpers --------------------------------------------------------

def _validate(model, data, where_of, key_prefix: str):
    """Validate with pydantic; re-raise the first error with file:line and key path."""
    try:
        return model.model_validate(data)
    except ValidationError as e:
        raise config_error(e, model, where=where_of, key_prefix=key_prefix) from None


# -- expansion -----------------------------------------------------------------

def _split_connection(text: str, where) -> list[tuple[str, str]]:
    if "->" not in text:
        raise ConfigError(f"connection '{text}' needs the form 'component.output -> component.input'", where)
    src, dsts = text.split("->", 1)
    src = src.strip()
    targets = [d.strip() for d in dsts.split(",") if d.strip()]
    if not src or not targets:
        raise ConfigError(f"connection '{text}' needs the form 'component.output -> component.input'", where)
    return [(src, d) for d in targets]


def _prefixed(path: str, prefix: str | None) -> str:
    return f"{prefix}/{path}" if prefix else path


def _check_top_level(data: dict) -> None:
    """One layer's top-level keys (an assembly, an included one, a ``--config`` file, a ``--set``): known
    keys, each of its type. Checked per layer, before merging: a later layer must not hide a bad value."""
    unknown = [k for k in data if k not in TOP_KEYS]
    if unknown:
        k = unknown[0]
        close = difflib.get_close_matches(str(k), TOP_KEYS, n=1)
        raise ConfigError(f"unknown top-level key '{k}'" + (f"; did you mean '{close[0]}'?" if close else "")
                          + f" (valid: {', '.join(TOP_KEYS)})", data.where(k) if hasattr(data, "where") else None, k)
    for k, (kind, what) in _TOP_TYPES.items():
        if data.get(k) is not None and not isinstance(data[k], kind):
            got = next((w for t, w in ((bool, "a boolean"), (int, "a number"), (float, "a number"), (str, "a string"),
                                       (list, "a list"), (dict, "a mapping")) if isinstance(data[k], t)), "a value")
            keys = f"; valid keys: {', '.join(_TOP_SCHEMAS[k].model_fields)}" if k in _TOP_SCHEMAS else ""
            raise ConfigError(f"'{k}' must be {what}, got {got}: {str(data[k])[:60]!r}{keys}",
                              data.where(k) if hasattr(data, "where") else None, k)


#: a component's full name: parts of letters, digits, '_' and '-', joined by '/' (an include's prefix);
#: '.' separates the component from its port in 'comp.port', and ',', '->' and spaces split connections
_NAME = re.compile(r"[A-Za-z0-9_-]+(/[A-Za-z0-9_-]+)*")
_NAME_RULE = "letters, digits, '_' and '-', with '/' between an include's prefix and the name"


def _check_name(name: str, what: str, where, key: str) -> None:
    if not _NAME.fullmatch(name):
        bad = sorted({c for c in name if not (c.isascii() and (c.isalnum() or c in "_-/"))})
        why = f"it contains {', '.join(repr(c) for c in bad)}" if bad else "an empty part between '/'"
        raise ConfigError(f"{what} '{name}' is not a valid name ({why}): a name is used in 'component.port' "
                          f"references and connections, so it may hold only {_NAME_RULE}", where, key)


def _expand(data: LocatedDict, scope: dict, prefix: str | None, search_path, base_dir: Path,
            out: dict, depth: int = 0) -> None:
    if depth > 20:
        raise ConfigError("includes nest more than 20 deep (an assembly includes itself?)", data.where())
    _check_top_level(data)

    # includes first, so the including file can wire and record into them
    includes = data.get("include") or []
    if not isinstance(includes, list):
        raise ConfigError("'include' must be a list", data.where("include"), "include")
    for n, raw in enumerate(includes):
        where = includes.where(n) if hasattr(includes, "where") else None
        if not isinstance(raw, dict):
            raise ConfigError(f"include entries are mappings with 'assembly', got {raw!r}", where, f"include[{n}]")
        # 'as' and 'params' may use the index ${i}: substituted per repetition below
        head = dict(raw, repeat=substitute(raw.get("repeat", 1), scope), assembly=substitute(raw.get("assembly", ""), scope))
        inc = _validate(IncludeSpec, head, lambda loc: where_in(raw, loc) or where, f"include[{n}]")
        for i in range(inc.repeat):
            iscope = dict(scope, i=i)
            params = substitute(raw.get("params", {}) or {}, iscope)
            try:
                path = find_assembly(substitute(inc.assembly, iscope), search_path, base_dir)
            except ConfigError as e:
                raise ConfigError(e.detail, where_in(raw, ["assembly"]) or where, f"include[{n}].assembly") from None
            sub = locate_strings(load_yaml(path))     # its paths are relative to it
            if not isinstance(sub, dict):
                raise ConfigError(f"included assembly {path} is not a YAML mapping (got {type(sub).__name__}); "
                                  "an assembly maps keys such as components and connections",
                                  where_in(raw, ["assembly"]) or where, f"include[{n}].assembly")
            if not isinstance(sub.get("parameters") or {}, dict):
                raise ConfigError("'parameters' must be a mapping", sub.where("parameters"), "parameters")
            declared = dict(sub.get("parameters") or {})
            bad = [k for k in params if k not in declared]
            if bad:
                raise ConfigError(f"'{bad[0]}' is not a parameter of {path.name} "
                                  f"(it declares: {', '.join(declared) or 'none'})",
                                  where_in(raw, ["params", bad[0]]) or where, f"include[{n}].params.{bad[0]}")
            sub_scope = deep_merge(declared, params)
            sub_scope["i"] = i
            name = substitute(raw.get("as"), iscope) if raw.get("as") else (
                path.stem + (str(i) if inc.repeat > 1 else ""))
            _check_name(str(name), "include prefix" if raw.get("as") else f"include prefix (from the file name {path.name};"
                        " give 'as')", where_in(raw, ["as"]) or where, f"include[{n}].as")
            _expand(sub, sub_scope, _prefixed(str(name), prefix), search_path, path.parent, out, depth + 1)

    comps = substitute(data.get("components") or LocatedDict(), scope)
    if not isinstance(comps, dict):
        raise ConfigError("'components' must be a mapping of name -> {type, params, rate}",
                          data.where("components"), "components")
    for cname, spec in comps.items():
        full = _prefixed(str(cname), prefix)
        where = comps.where(cname) if hasattr(comps, "where") else None
        if "/" in str(cname) and prefix is None and full in out["components"]:
            # a patch of an included component (e.g. from a config file)
            merged = deep_merge(out["components_raw"][full], spec)
            out["components_raw"][full] = merged
            continue
        if full in out["components"] and not (isinstance(spec, dict) and "type" not in spec):
            raise ConfigError(f"component '{full}' defined twice (also at {out['where'][full]})", where, f"components.{cname}")
        _check_name(full, "component name", where, f"components.{cname}")
        out["components_raw"][full] = spec
        out["components"][full] = None
        out["where"][full] = where

    conns = data.get("connections") or []
    for n, item in enumerate(conns):
        where = conns.where(n) if hasattr(conns, "where") else None
        if isinstance(item, dict):
            extra = set(item) - {"connect", "repeat"}
            if "connect" not in item or extra:
                raise ConfigError("a connection mapping has keys 'connect' and optional 'repeat'", where, f"connections[{n}]")
            reps = substitute(item.get("repeat", 1), scope)
            if not isinstance(reps, int) or isinstance(reps, bool) or not 0 <= reps <= MAX_REPEAT:
                raise ConfigError(f"repeat must be an integer from 0 to {MAX_REPEAT} (the limit), got {reps!r}",
                                  where, f"connections[{n}].repeat")
            texts = [substitute(item["connect"], dict(scope, i=i)) for i in range(reps)]
        elif isinstance(item, str):
            texts = [substitute(item, scope)]
        else:
            raise ConfigError(f"connection must be a string 'a.y -> b.u', got {item!r}", where, f"connections[{n}]")
        for text in texts:
            for s, t in _split_connection(text, where):
                out["connections"].append((_prefixed(s, prefix), _prefixed(t, prefix), where))

    rec = data.get("record") or []
    for n, item in enumerate(rec):
        where = rec.where(n) if hasattr(rec, "where") else None
        if not isinstance(item, str):
            raise ConfigError(f"record entries are 'component.port' strings, got {item!r}", where, f"record[{n}]")
        out["record"].append((_prefixed(substitute(item, scope), prefix), where))

    stops = data.get("stop") or []
    for n, item in enumerate(stops):
        where = stops.where(n) if hasattr(stops, "where") else None
        item = substitute(item, scope)
        spec = _validate(StopSpec, item, lambda loc: where_in(item, loc) or where, f"stop[{n}]")
        if sum(v is not None for v in (spec.above, spec.below, spec.abs_above)) != 1:
            raise ConfigError("a stop condition needs exactly one of above, below, abs_above", where, f"stop[{n}]")
        spec = spec.model_copy(update={"signal": _prefixed(spec.signal, prefix)})
        out["stop"].append((spec, where))


def _sim_layer(values: dict) -> LocatedDict:
    """The layer of the explicit command-line flags (``--dt``, ``--integrator``...): ``sim`` keys."""
    flags = LocatedDict(values)
    layer = LocatedDict(sim=flags)
    layer.file = flags.file = "command line"
    return layer


def _check_declared(given: dict, declared: dict, key: str, assembly: str) -> None:
    """A later layer may set parameters the assembly declares, never invent one (a typo)."""
    for k, v in given.items():
        if k not in declared:
            close = difflib.get_close_matches(str(k), [str(d) for d in declared], n=3, cutoff=0.5)
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            where = given.where(k) if hasattr(given, "where") else None
            raise ConfigError(f"'{k}' is not a parameter of {assembly} (it declares: "
                              f"{', '.join(map(str, declared)) or 'none'}){hint}", where, f"{key}.{k}")
        if isinstance(v, dict) and isinstance(declared[k], dict):
            _check_declared(v, declared[k], f"{key}.{k}", assembly)


def resolve(assembly: str | Path | None, *, search_path=(), config_files=(), overrides=(),
            sim_overrides: dict | None = None) -> Resolved:
    """Load, layer and expand an assembly into a :class:`Resolved` configuration.

    Precedence (later wins): the assembly file, each config file in order,
    each ``--set`` in order, then ``sim_overrides`` (explicit CLI flags).
    """
    path = find_assembly(str(assembly), search_path)
    data = locate_strings(load_yaml(path))       # paths in a file are relative to that file (paths.py)
    if not isinstance(data, dict):
        raise ConfigError("an assembly must be a YAML mapping", str(path))
    _check_top_level(data)
    declared = data.get("parameters") or {}
    flags = None
    if sim_overrides:
        flags = LocatedDict({k: v for k, v in sim_overrides.items() if v is not None})
        flags.file = "command line"
    if flags and "integrator" in flags:
        # --integrator chooses the integrator the layers below it refine: a config file's or --set's
        # sim.integrator.params (no name) are for it, so it is chosen first, then again last (it wins)
        data = merge_layer(data, _sim_layer({"integrator": flags["integrator"]}))
    for cf in config_files:
        layer = locate_strings(load_yaml(cf))
        if not isinstance(layer, dict):
            raise ConfigError("a config file must be a YAML mapping", str(cf))
        _check_top_level(layer)
        data = merge_layer(data, layer)
    for item in overrides:
        params_now = data.get("parameters")
        layer = set_override(item, dict(params_now) if isinstance(params_now, dict) else {})
        _check_top_level(layer)
        data = merge_layer(data, layer)
    if flags:
        data = merge_layer(data, _sim_layer(flags))

    parameters = data.get("parameters") or LocatedDict()
    if not isinstance(parameters, dict):
        raise ConfigError("'parameters' must be a mapping", data.where("parameters"), "parameters")
    _check_declared(parameters, declared, "parameters", path.name)
    out = {"components": {}, "components_raw": {}, "where": {}, "connections": [], "record": [], "stop": []}
    _expand(data, dict(parameters), None, search_path, path.parent, out)

    components = {}
    for name, raw in out["components_raw"].items():
        where = out["where"][name]
        if not isinstance(raw, dict):
            raise ConfigError(f"component '{name}' must be a mapping with 'type'", where, f"components.{name}")
        if "type" not in raw:
            raise ConfigError(f"component '{name}' has no 'type' (a patch for a component that does not exist?)",
                              where, f"components.{name}")
        components[name] = _validate(ComponentSpec, raw, lambda loc, raw=raw, w=where: where_in(raw, loc) or w,
                                     f"components.{name}")
    if not components:
        raise ConfigError("the assembly has no components: nothing to simulate (give 'components', or "
                          "'include' an assembly that has some)", str(path), "components")
    sim_raw = substitute(data.get("sim") or LocatedDict(), dict(parameters))
    sim = _validate(SimSpec, sim_raw, lambda loc: where_in(sim_raw, loc) or data.where("sim"), "sim")
    return Resolved(sim=sim, parameters=dict(parameters), components=components,
                    connections=out["connections"], record=out["record"], stop=out["stop"],
                    description=str(data.get("description") or ""), where=out["where"], source=str(path))
