"""Build-time checks of the connections: names, directions, types, shapes, units.

Everything here runs once, before the first step; every error names both ends
of the offending connection and where it was written.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

import numpy as np

from .component import Component
from .errors import BuildError
from .signals import Structured, normalize_unit, resolve_shape


@dataclass(frozen=True)
class PortRef:
    comp: str
    port: str

    def __str__(self) -> str:
        return f"{self.comp}.{self.port}"


@dataclass
class PortInfo:
    signal: object
    shape: tuple | None
    unit: str | None
    role: str | None = None

    def describe(self) -> str:
        return self.signal.describe(self.shape) if not isinstance(self.signal, Structured) else self.signal.describe()


def _at(where) -> str:
    return f" ({where})" if where else ""


def _close(name, options) -> str:
    m = difflib.get_close_matches(name, list(options), n=3, cutoff=0.5)
    return f"; did you mean {', '.join(m)}?" if m else ""


def port_infos(comp: Component) -> dict[str, PortInfo]:
    out = {}
    for name, port in {**comp.inputs, **comp.outputs}.items():
        sig = port.signal
        if isinstance(sig, Structured):
            out[name] = PortInfo(sig, None, None, port.role)
            continue
        try:
            shape = resolve_shape(sig.shape, comp, f"{comp.name}.{name}")
        except (AttributeError, ValueError, TypeError) as e:
            raise BuildError(str(e)) from None
        out[name] = PortInfo(sig, shape, normalize_unit(sig.unit), port.role)
    return out


def parse_ref(text: str, components: dict[str, Component], role: str, where) -> PortRef:
    """'a/b.port' -> PortRef, checking the component and that the port exists with the role."""
    if "." not in text:
        raise BuildError(f"'{text}'{_at(where)}: expected 'component.port'")
    comp, port = text.rsplit(".", 1)
    if comp not in components:
        raise BuildError(f"'{text}'{_at(where)}: no component '{comp}'{_close(comp, components)}")
    c = components[comp]
    ports = c.outputs if role == "output" else c.inputs
    if port not in ports:
        other = c.inputs if role == "output" else c.outputs
        if port in other:
            raise BuildError(f"'{text}'{_at(where)}: '{port}' is an {'input' if role == 'output' else 'output'} "
                             f"of {comp} ({c.type_name}); a connection goes output -> input")
        raise BuildError(f"'{text}'{_at(where)}: {comp} ({c.type_name}) has no {role} '{port}'"
                         f"{_close(port, ports)}; its {role}s: {', '.join(ports) or 'none'}")
    return PortRef(comp, port)


def check_compatible(src: PortRef, si: PortInfo, dst: PortRef, di: PortInfo, where) -> None:
    problem = None
    s_struct, d_struct = isinstance(si.signal, Structured), isinstance(di.signal, Structured)
    if s_struct != d_struct:
        problem = "one end is structured, the other numeric"
    elif s_struct:
        if not issubclass(si.signal.cls, di.signal.cls):
            problem = "structured types differ"
    else:
        if np.dtype(si.signal.dtype) != np.dtype(di.signal.dtype):
            problem = "dtypes differ"
        elif di.shape is not None and si.shape != di.shape:
            problem = "shapes differ"
        elif di.unit is not None and si.unit is not None and si.unit != di.unit:
            problem = "units differ"
    if problem is None and si.role and di.role and si.role != di.role:
        problem = f"the source carries {si.role}, the input expects {di.role}"
    if problem:
        raise BuildError(f"cannot connect {src} ({si.describe()}) -> {dst} ({di.describe()}){_at(where)}: {problem}")
