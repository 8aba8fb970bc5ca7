"""Configuration layering: assembly < config files < ``--set`` < explicit CLI flags.

Mappings merge deeply, key by key; any other value (lists included) is
replaced whole by the later layer, and so is a camera ``model`` whose ``kind``
the later layer changes (pinhole to cahv: the pinhole's keys do not carry over,
:data:`KIND_BLOCKS`), as is the integrator when another is named. Every merged mapping keeps the position of
the layer each key came from, so errors still point at the right file.
"""

from __future__ import annotations

import difflib

from .errors import ConfigError
from .yaml_source import LocatedDict, load_yaml_text

#: top-level keys of an assembly / resolved configuration
TOP_KEYS = ("description", "parameters", "sim", "include", "components", "connections", "record", "stop")


def deep_merge(base, over):
    if not (isinstance(base, dict) and isinstance(over, dict)):
        return over
    out = LocatedDict()
    out.file = getattr(over, "file", None) or getattr(base, "file", None)
    out.line = getattr(over, "line", None) or getattr(base, "line", None)
    for layer in (base, over):
        pos = getattr(layer, "pos", {})
        for k in layer:
            out.pos[k] = pos.get(k, (getattr(layer, "file", None), None))
    for k, v in base.items():
        out[k] = v
    for k, v in over.items():
        out[k] = v if k in KIND_BLOCKS and _switches_kind(base[k], v) else deep_merge(base[k], v) if k in base else v
    return out


#: keys whose mapping is one of several schemas picked by its ``kind``, with keys of their own (a camera
#: ``model``: a pinhole's ``fov`` is no CAHV key): a later layer naming another kind replaces the block
#: whole, so the earlier kind's keys are neither carried over nor blamed on the later file. Mappings whose
#: kinds share keys (a gait's params, a placement ``shape`` and its ``pose``) merge key by key as any other.
KIND_BLOCKS = frozenset({"model"})


def _switches_kind(base, over) -> bool:
    return (isinstance(base, dict) and isinstance(over, dict) and "kind" in base and "kind" in over
            and base["kind"] != over["kind"])


def merge_layer(base, over):
    """``deep_merge`` of one configuration layer over the layers below it.

    ``sim.integrator`` may be a bare name: a later mapping refines the earlier
    integrator (``--set sim.integrator.params.rtol=1e-8`` over ``integrator:
    dopri5``), and one naming a different integrator replaces it, params and all.
    """
    sim, over_sim = (base.get("sim"), over.get("sim")) if isinstance(base, dict) and isinstance(over, dict) else (None, None)
    if isinstance(sim, dict) and isinstance(over_sim, dict) and "integrator" in sim \
            and isinstance(over_sim.get("integrator"), dict):
        old = sim["integrator"]
        old = {"name": old} if isinstance(old, str) else old
        if isinstance(old, dict) and over_sim["integrator"].get("name", old.get("name")) != old.get("name"):
            old = {}
        base = _with(base, "sim", _with(sim, "integrator", old))
    elif isinstance(sim, dict) and isinstance(over_sim, dict) and isinstance(over_sim.get("integrator"), str) \
            and isinstance(sim.get("integrator"), dict) and sim["integrator"].get("name") in (None, over_sim["integrator"]):
        # a bare name over params given for that integrator (or for whichever one is chosen, by --set
        # sim.integrator.params.X): the params stay; a different integrator's params are replaced
        over = _with(over, "sim", _with(over_sim, "integrator", {"name": over_sim["integrator"]}))
    return deep_merge(base, over)


def _with(d: dict, key, value) -> LocatedDict:
    """A copy of mapping ``d`` (positions kept) with ``key`` set to ``value``."""
    out = LocatedDict(d)
    out.pos = dict(getattr(d, "pos", {}))
    out.file, out.line = getattr(d, "file", None), getattr(d, "line", None)
    out[key] = value
    return out


def parse_set(item: str) -> tuple[list[str], object]:
    """``a.b.c=value`` -> (["a","b","c"], value parsed as a YAML scalar/flow value)."""
    if "=" not in item:
        raise ConfigError(f"'--set {item}' needs the form key.path=value", "--set")
    key, raw = item.split("=", 1)
    key = key.strip()
    if not key or any(not part for part in key.split(".")):
        raise ConfigError(f"'--set {item}': empty key in '{key}'", "--set")
    try:
        value = load_yaml_text(raw, "--set") if raw.strip() else ""
    except ConfigError as e:
        raise ConfigError(f"'--set {item}': value '{raw}' is not valid YAML ({e.detail})", "--set") from None
    return key.split("."), value


def set_override(item: str, parameters: dict) -> LocatedDict:
    """Turn one ``--set`` into a nested mapping to merge.

    A path whose first key is not a top-level key (``sim``, ``components``…)
    addresses an assembly parameter: ``--set robot.modules=4`` is
    ``parameters.robot.modules``.
    """
    path, value = parse_set(item)
    if path[0] not in TOP_KEYS:
        if path[0] not in parameters:
            options = list(TOP_KEYS) + list(parameters)
            close = difflib.get_close_matches(path[0], options, n=3, cutoff=0.5)
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise ConfigError(
                f"'{path[0]}' is neither a top-level key ({', '.join(TOP_KEYS)}) nor a parameter of "
                f"this assembly ({', '.join(parameters) or 'it has none'}){hint}", "--set", ".".join(path))
        path = ["parameters"] + path
    node = value
    for part in reversed(path):
        d = LocatedDict()
        d.file = "--set"
        d[part] = node
        node = d
    return node
