"""Namespace objects handed to component methods as ``u`` (inputs) and ``y`` (outputs).

Built once per component at build time as small slotted classes, so reading
``u.q`` in the hot loop is a slot load, not a dict look-up. The inputs
namespace also carries ``u.cache``, the component's per-run cache (what its
``make_cache()`` returned for this plan), since every method receives ``u``. Numeric inputs are
read-only views of the upstream output arrays (zero copy); structured values
travel through a shared cell. Rebinding a numeric output (``y.tau = ...``)
would silently break the wiring, so it raises and says to write in place.
"""

from __future__ import annotations

from typing import Any


class Cell:
    """Holds one structured value; shared by the producing output and its readers."""

    __slots__ = ("value",)

    def __init__(self, value: Any = None):
        self.value = value


def _cell_property(name: str, writable: bool):
    slot = "_cell_" + name

    def get(self):
        return getattr(self, slot).value

    if not writable:
        return property(get)

    def set_(self, value):
        getattr(self, slot).value = value

    return property(get, set_)


def make_namespace(owner: str, role: str, numeric: dict[str, Any], cells: dict[str, Cell]):
    """Create an instance with slots for ``numeric`` arrays and properties for ``cells``."""
    writable = role == "outputs"
    extra = ("cache",) if role == "inputs" else ()
    attrs: dict[str, Any] = {"__slots__": tuple(numeric) + tuple("_cell_" + n for n in cells) + extra}
    for n in cells:
        attrs[n] = _cell_property(n, writable)
    frozen_names = frozenset(numeric)

    def __setattr__(self, name, value):
        if name in frozen_names:
            if value is getattr(self, name):
                return  # ``y.a += b`` works in place, then rebinds the same array: harmless
            hint = f"write into the buffer instead: y.{name}[...] = value" if writable else "inputs are read-only"
            raise AttributeError(f"{owner}: cannot rebind {role} '{name}'; {hint}")
        if name in extra:
            raise AttributeError(f"{owner}: u.cache is made by the framework (make_cache()), not rebound")
        if name in cells:
            if not writable:
                raise AttributeError(f"{owner}: cannot rebind {role} '{name}'; inputs are read-only")
            object.__setattr__(self, name, value)
            return
        raise AttributeError(f"{owner} has no {role[:-1]} '{name}'")

    def __repr__(self):
        return f"<{owner} {role}: {', '.join(list(numeric) + list(cells))}>"

    attrs["__setattr__"] = __setattr__
    attrs["__repr__"] = __repr__
    cls = type(f"{role.capitalize()}", (), attrs)
    ns = cls()
    for n, arr in numeric.items():
        object.__setattr__(ns, n, arr)
    for n, cell in cells.items():
        object.__setattr__(ns, "_cell_" + n, cell)
    if extra:
        object.__setattr__(ns, "cache", None)
    return ns


def set_cache(u, cache) -> None:
    """The framework's one way to hand a component its per-run cache (``u.cache``)."""
    object.__setattr__(u, "cache", cache)
