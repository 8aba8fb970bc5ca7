"""A pydantic ``ValidationError`` as one :class:`~.errors.ConfigError` a user can act on.

Every schema a user writes (assembly sections, component Params, terrain files) is checked by
pydantic; :func:`config_error` turns its report into the one error we print: the file:line of the
offending key, the dotted key path, and a message that says what would be valid::

    scene.yaml:4: sim.dtt: unknown key 'dtt'; did you mean 'dt'? valid keys: dt, t_end, ...
    t.yaml:2: radius: Input should be greater than 0 (got 0.0)
    o.yaml:3: boxes.0.center: needs 3 values, got 2: [0, 0]

Rules: a typo (an extra key) is reported before what it leaves missing; a validator's
"Value error, " prefix is dropped; a scalar input is quoted (at most 80 characters); a tuple given
too few values says how many it needs; an unknown key lists the keys of the model that holds it.

:func:`where_in` finds the deepest file:line known for a key path in located YAML data
(:mod:`~.yaml_source`), the usual ``where`` argument.
"""

from __future__ import annotations

import difflib
from typing import Callable, get_args

from pydantic import BaseModel, ValidationError

from .errors import ConfigError


def config_error(e: ValidationError, model: type[BaseModel] | None = None, *,
                 where: str | Callable[[list], str | None] | None = None, key_prefix: str = "",
                 drop: object = None, unknown: str = "key", owner: str | None = None) -> ConfigError:
    """The ConfigError for ``e``, raised by validating against ``model`` (the model whose fields an
    unknown key is checked against; None: unknown keys are named without a list).

    ``where``: the file:line, or a function of the error's key path (a list) that returns it.
    ``key_prefix``: the dotted path of the validated mapping (``components.pend.params``).
    ``drop``: a value removed from the key path (a discriminated union's tag, such as the ``kind``).
    ``unknown``/``owner``: the wording of an unknown top-level key, "unknown {unknown} 'x'; ...
    {owner} takes: a, b" (default "unknown key 'x'; ... valid keys: a, b").
    """
    errs = e.errors()
    err = next((x for x in errs if x["type"] == "extra_forbidden"), errs[0])   # a typo explains 'missing'
    loc = [x for x in err["loc"] if drop is None or not (isinstance(x, str) and x == drop)]
    msg = _message(err)
    short = _short_tuple(err, loc, model)
    if short is not None:
        loc, msg = short
    if err["type"] == "extra_forbidden" and loc:
        holder = _model_at(model, loc)
        top = len(loc) == 1
        msg = _unknown_key(loc[-1], holder.model_fields if holder is not None else None,
                           unknown if top else "key", owner if top else None)
    at = where(loc) if callable(where) else where
    key = ".".join([key_prefix] * bool(key_prefix) + [str(x) for x in loc])
    return ConfigError(msg, at, key or None)


def where_in(node, loc) -> str | None:
    """The deepest file:line known for the key path ``loc`` inside located data (None if none)."""
    best = node.where() if hasattr(node, "where") else None
    for part in loc:
        if isinstance(node, dict) and part in node:
            best = (node.where(part) if hasattr(node, "where") else None) or best
            node = node[part]
        elif isinstance(node, list) and str(part).isdigit() and int(part) < len(node):
            best = (node.where(int(part)) if hasattr(node, "where") else None) or best
            node = node[int(part)]
        else:
            break
    return best


def _message(err: dict) -> str:
    msg = err["msg"]
    if err["type"] == "value_error":
        return msg.removeprefix("Value error, ")
    if "input" in err and not isinstance(err["input"], dict):
        got = repr(err["input"])
        return f"{msg} (got {got if len(got) <= 80 else got[:77] + '...'})"
    return msg


def _short_tuple(err: dict, loc: list, model) -> tuple[list, str] | None:
    """A list with too few values is reported by pydantic as its first missing item: say so."""
    if err["type"] != "missing" or not loc or not isinstance(loc[-1], int) or not isinstance(err.get("input"), list):
        return None
    holder = _model_at(model, loc[:-1])
    field = holder.model_fields.get(loc[-2]) if holder is not None and isinstance(loc[-2], str) else None
    want = f"{len(get_args(field.annotation))} values" if field is not None else f"more than {len(err['input'])} values"
    return loc[:-1], f"needs {want}, got {len(err['input'])}: {err['input']!r}"


def _model_at(model, loc):
    """The schema model that holds the key at the end of ``loc`` (None if the path leaves the schema)."""
    for part in loc[:-1]:
        if isinstance(part, int):
            continue                                   # a list entry: same item model
        field = model.model_fields.get(part) if model is not None else None
        if field is None:
            return None
        model = _model_in(field.annotation)
    return model


def _model_in(annotation):
    """The BaseModel class inside an annotation such as ``X``, ``list[X]`` or ``X | None``."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in get_args(annotation):
        found = _model_in(arg)
        if found is not None:
            return found
    return None


def _unknown_key(key, valid, noun: str = "key", owner: str | None = None) -> str:
    msg = f"unknown {noun} '{key}'"
    if valid is None:
        return msg
    close = difflib.get_close_matches(str(key), list(valid), n=1)
    listing = f"{owner} takes" if owner else f"valid {noun}s"
    return msg + (f"; did you mean '{close[0]}'?" if close else ";") + f" {listing}: {', '.join(valid) or 'none'}"
