"""Build-time resources: a model one component builds and others are handed (Drake's plant).

A component that builds something its neighbours need at build time (the
robot model: link and joint layout, frames, geometry) declares it::

    class Multibody(Component):
        robot = Provides(RobotModel, doc="the built robot")   # setup() assigns self.robot

and a component that needs it declares::

    class JointPid(Component):
        robot = Uses(RobotModel)        # self.robot is bound before setup() runs

The build instantiates providers before their users and hands each user the
provider's object, so a scene names its robot once. An assembly names the
provider (``uses: {robot: NAME}``) only when several components provide that
kind; with exactly one it is bound by kind. A resource is build-time
configuration: it is read-only during a run and holds no per-run state.
Port shapes may depend on it (``shape=lambda c: (c.robot.nj,)``), since ports
are resolved after ``setup()``.
"""

from __future__ import annotations

from typing import Any


class ResourceBindingError(ValueError):
    """A use that cannot be bound; ``component`` names the component whose entry is at fault."""

    def __init__(self, component: str | None, message: str):
        super().__init__(message)
        self.component = component


class _ResourceSlot:
    role = "resource"

    def __init__(self, kind: type, *, doc: str = ""):
        self.kind = kind
        self.doc = doc
        self.name = "?"

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        # an instance attribute shadows this (non-data) descriptor once bound
        raise AttributeError(f"{obj.name}: {self.role} '{self.name}' ({self.kind.__name__}) is not bound yet"
                             + (" (setup() must assign it)" if self.role == "provides" else ""))

    def describe(self) -> str:
        return self.kind.__name__


class Uses(_ResourceSlot):
    """A build-time resource the component needs; ``required=False`` binds None when none is provided."""

    role = "uses"

    def __init__(self, kind: type, *, required: bool = True, doc: str = ""):
        super().__init__(kind, doc=doc)
        self.required = required


class Provides(_ResourceSlot):
    """A build-time resource the component builds in ``setup()`` and hands to its users."""

    role = "provides"


def provider_order(classes: dict[str, type], explicit: dict[str, dict[str, str]]) -> tuple[list[str], dict]:
    """Bind every ``Uses`` to a provider and order instantiation providers-first.

    classes:  component name -> component class
    explicit: component name -> {uses slot: provider component name} from the assembly
    Returns (names in instantiation order, {name: {slot: (provider name, provider slot) or None}}).
    Raises ResourceBindingError naming the component, the slot and the valid choices.
    """
    offers = [(n, slot, prov.kind) for n, cls in classes.items() for slot, prov in cls.provides.items()]
    binding: dict[str, dict[str, tuple[str, str] | None]] = {}
    for name, cls in classes.items():
        kind_name = cls.type_name or cls.__name__
        given = dict(explicit.get(name) or {})
        unknown = [k for k in given if k not in cls.uses]
        if unknown:
            raise ResourceBindingError(name, f"{name}: 'uses' names '{unknown[0]}', which {kind_name} does not "
                                             f"use; it uses: {', '.join(cls.uses) or 'nothing'}")
        binding[name] = {}
        for slot, use in cls.uses.items():
            fits = [(n, s) for n, s, kind in offers if n != name and issubclass(kind, use.kind)]
            want = use.kind.__name__
            if slot in given:
                target = given[slot]
                chosen = [(n, s) for n, s in fits if n == target]
                if not chosen:
                    valid = ", ".join(n for n, _ in fits) or "none in this scene"
                    raise ResourceBindingError(name, f"{name}: uses.{slot} = '{target}', which does not provide "
                                                     f"a {want}; components that do: {valid}")
                binding[name][slot] = chosen[0]
            elif len(fits) == 1:
                binding[name][slot] = fits[0]
            elif not fits:
                if use.required:
                    raise ResourceBindingError(name, f"{name} ({kind_name}) uses a {want} ('{slot}'), and no "
                                                     f"component in the scene provides one; add the component "
                                                     f"that builds it (e.g. the robot's multibody)")
                binding[name][slot] = None
            else:
                raise ResourceBindingError(name, f"{name} ({kind_name}) uses a {want} ('{slot}') and {len(fits)} "
                                                 f"components provide one ({', '.join(n for n, _ in fits)}); "
                                                 f"name one with 'uses: {{{slot}: NAME}}'")
    order: list[str] = []
    state: dict[str, int] = {}

    def visit(n: str, path: list[str]):
        if state.get(n) == 2:
            return
        if state.get(n) == 1:
            raise ResourceBindingError(None, "resources used in a cycle: " + " -> ".join(path + [n]))
        state[n] = 1
        for b in binding[n].values():
            if b is not None:
                visit(b[0], path + [n])
        state[n] = 2
        order.append(n)

    for n in classes:
        visit(n, [])
    return order, binding


def resolve_uses(binding: dict[str, tuple[str, str] | None], built: dict[str, Any]) -> dict[str, Any]:
    """{slot: resource object} for one component, from its providers' built instances."""
    return {slot: None if b is None else getattr(built[b[0]], b[1]) for slot, b in binding.items()}
