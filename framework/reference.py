"""The component reference, generated from the registry so it never goes stale."""

from __future__ import annotations

import inspect
import types
import typing


def _signal(port) -> str:
    return port.describe() + (f" (role: {port.role})" if port.role else "")


def type_name(annotation) -> str:
    """A parameter's type as a reader wants it: a ``Literal``'s choices spelled out, unions joined by ``|``."""
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is typing.Literal:
        return "one of " + ", ".join(repr(a) for a in args)
    if origin in (typing.Union, types.UnionType):
        return " | ".join(type_name(a) for a in args)
    if origin is typing.Annotated:
        return type_name(args[0])
    if args:
        return f"{getattr(origin, '__name__', str(origin))}[{', '.join(type_name(a) for a in args)}]"
    if annotation is type(None):
        return "None"
    if annotation is Ellipsis:
        return "..."
    return getattr(annotation, "__name__", str(annotation))


def component_reference(registry) -> dict:
    out = {}
    for name in sorted(registry.components):
        cls = registry.components[name]
        # the class's own docstring (getdoc would inherit typing.Generic's), else its module's
        own = cls.__dict__.get("__doc__")
        doc = inspect.cleandoc(own) if own else inspect.getdoc(inspect.getmodule(cls)) or ""
        params = []
        for pname, f in cls.Params.model_fields.items():
            # required parameters have no default: say so (and keep the reference JSON-clean)
            default = "(required)" if f.is_required() else f.get_default(call_default_factory=True)
            if hasattr(default, "model_dump"):      # a nested parameter model (e.g. a Material)
                default = default.model_dump(mode="json")
            params.append({"name": pname, "type": type_name(f.annotation),
                           "default": default, "description": f.description or ""})
        out[name] = {
            "class": cls.__qualname__, "module": cls.__module__,
            "summary": doc.strip().split("\n\n")[0].replace("\n", " ") if doc.strip() else "",
            "doc": doc.strip(),
            "inputs": [{"name": n, "signal": _signal(p), "required": p.required, "doc": p.doc}
                       for n, p in cls.inputs.items()],
            "outputs": [{"name": n, "signal": _signal(p),
                         "feedthrough": list(p.feedthrough_inputs(list(cls.inputs))), "doc": p.doc}
                        for n, p in cls.outputs.items()],
            "params": params,
            "uses": [{"name": n, "kind": u.kind.__name__, "required": u.required, "doc": u.doc}
                     for n, u in cls.uses.items()],
            "provides": [{"name": n, "kind": pr.kind.__name__, "doc": pr.doc} for n, pr in cls.provides.items()],
            "sink": cls.is_sink,
        }
    return out


def _cell(text) -> str:
    """A Markdown table cell: a '|' inside (``float | None``) would split it."""
    return str(text).replace("|", "\\|")


def reference_markdown(ref: dict) -> str:
    lines = ["# Component reference", "",
             "Generated from the registry by `snakesim components --markdown`; do not edit by hand.", ""]
    for name, c in ref.items():
        lines += [f"## `{name}`", "", c["summary"], ""]
        rest = c["doc"].split("\n\n", 1)[1].strip("\n") if "\n\n" in c["doc"] else ""
        if rest:     # the whole docstring, as written: port layouts and equations keep their columns
            lines += ["```text", rest, "```", ""]
        lines += [f"`{c['module']}.{c['class']}`", ""]
        for r in c["provides"]:
            lines += [f"Provides `{r['name']}`: {r['kind']}" + (f" ({r['doc']})" if r["doc"] else "") + ".", ""]
        for r in c["uses"]:
            lines += [f"Uses `{r['name']}`: {r['kind']}" + ("" if r["required"] else ", if a component provides one")
                      + " (bound to the component that provides it).", ""]
        if c["inputs"] or c["outputs"]:
            lines += ["| port | direction | signal | notes |", "|---|---|---|---|"]
            for p in c["inputs"]:
                lines.append(f"| `{p['name']}` | in | {_cell(p['signal'])} | {'required' if p['required'] else 'optional'} |")
            for p in c["outputs"]:
                ft = ", ".join(p["feedthrough"]) or "none (state only)"
                lines.append(f"| `{p['name']}` | out | {_cell(p['signal'])} | feedthrough: {ft} |")
            lines.append("")
        if c["params"]:
            lines += ["| parameter | type | default | description |", "|---|---|---|---|"]
            for p in c["params"]:
                lines.append(f"| `{p['name']}` | {_cell(p['type'])} | `{_cell(repr(p['default']))}` | {_cell(p['description'])} |")
            lines.append("")
    return "\n".join(lines) + "\n"
