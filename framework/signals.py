"""What flows on a port: numeric arrays (shape, dtype, unit) or structured values.

A numeric shape may name component parameters (``shape=("n", 3)``) or be a
callable of the component (``shape=lambda c: (c.robot.nj,)``: its params
``c.p``, the resources it uses and the constants ``setup()`` derived); it is
resolved once at build time, after ``setup()``. Element ``names`` likewise. Units are strings
compared after normalisation (``N·m`` == ``N*m``); ``unit=None`` on an input
accepts any unit, as generic blocks (gains, recorders) need.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable, Union

import numpy as np

ShapeSpec = Union[int, str, tuple, Callable[[Any], Any], None]


def normalize_unit(unit: str | None) -> str | None:
    if unit is None:
        return None
    u = unit.replace("·", "*").replace(" ", "").replace("^", "**")
    return u or "1"


def resolve_shape(spec: ShapeSpec, comp: Any, owner: str) -> tuple[int, ...] | None:
    """Turn a declared shape into a tuple of ints: callables get the component, names its params."""
    if spec is None:
        return None
    params = comp.p
    if callable(spec):
        spec = spec(comp)
    if isinstance(spec, (int, np.integer, str)):
        spec = (spec,)
    dims = []
    for d in spec:
        if isinstance(d, str):
            if not hasattr(params, d):
                raise AttributeError(f"{owner}: shape names parameter '{d}', which Params does not have")
            d = getattr(params, d)
        d = int(d)
        if d < 0:
            raise ValueError(f"{owner}: shape dimension {d} is negative")
        dims.append(d)
    return tuple(dims)


@dataclasses.dataclass(frozen=True)
class Numeric:
    """A numeric signal: a float (or other dtype) array of fixed shape."""

    shape: ShapeSpec = ()
    dtype: Any = np.float64
    unit: str | None = "1"
    names: tuple[str, ...] | Callable[[Any], tuple[str, ...]] | None = None

    def element_names(self, comp) -> tuple[str, ...] | None:
        """The element names for this component instance (a callable gets the component)."""
        return tuple(self.names(comp)) if callable(self.names) else self.names

    def describe(self, shape: tuple[int, ...] | None) -> str:
        s = "any shape" if shape is None else f"shape {shape}"
        return f"numeric {s} {np.dtype(self.dtype).name} [{self.unit if self.unit is not None else 'any unit'}]"


@dataclasses.dataclass(frozen=True)
class Structured:
    """A structured signal: instances of one frozen dataclass (Wrench, ContactSet, ...)."""

    cls: type

    def describe(self, shape=None) -> str:
        return f"structured {self.cls.__name__}"
