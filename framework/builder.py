"""Building a simulation from Python objects: Drake's ``DiagramBuilder``, pathsim's ``Simulation``.

::

    from snakesim.framework import Builder
    from snakesim.components.examples.pendulum import Pendulum, ViscousDamper

    b = Builder(dt=1e-3, integrator="rk4", duration=10.0)
    pend = b.add(Pendulum("pend", length=1.0, theta0=0.2))      # Params as keywords (or a Params)
    damper = b.add(ViscousDamper("damper", c=0.05))
    b.connect(pend.out.omega, damper.inp.omega)                  # port objects: .out / .inp
    b.connect(damper.out.tau, pend.inp.tau)
    b.record(pend.out.theta, damper.out.tau)
    b.stop(pend.out.theta, abs_above=3.2, reason="over the top")
    sim = b.build()                                              # a Simulation: advance_to, step, ...

The builder writes what an assembly file writes (connections, records, stops as ``component.port``
text, each with where it was written: the calling file and line) and hands it to the same build
(:func:`.plan.compile_plan`): the same checks, and the same errors naming both ends of a connection.
Resources bind as in an assembly: a component made without the resources it needs (a controller
using the robot model) is handed them at build, by kind, from the component that provides them
(``add(c, uses={"robot": "body"})`` names the provider when several do). :meth:`Builder.open`
declares an input set from Python (:meth:`.simulation.Simulation.set_input`), so a required input
may stay unconnected. An assembly goes through the same builder (:meth:`Builder.from_resolved`).
"""

from __future__ import annotations

import sys
from pathlib import Path

from .assembly import IntegratorSpec, SimSpec, StopSpec, _validate
from .component import Component
from .errors import BuildError, ConfigError
from .ports import PortHandle

_HERE = {Path(__file__).resolve()}


def _caller() -> str | None:
    """file:line of the first frame outside this module (where a builder call was written)."""
    f = sys._getframe(1)
    while f is not None and Path(f.f_code.co_filename).resolve() in _HERE:
        f = f.f_back
    if f is None:
        return None
    path = Path(f.f_code.co_filename)
    try:
        path = path.resolve().relative_to(Path.cwd())
    except ValueError:
        pass
    return f"{path}:{f.f_lineno}"


class Builder:
    """Components, connections, records, stops, open inputs and the sim settings; :meth:`build`."""

    def __init__(self, *, dt: float = 1e-3, duration: float = 10.0, integrator="rk4",
                 record_rate: float | None = None, t0: float = 0.0, realtime: bool = False, registry=None):
        """``integrator``: a name (``"rk4"``), ``{"name": ..., "params": {...}}``, or an integrator object."""
        self.registry = registry
        self.components: dict[str, Component] = {}
        self.uses: dict[str, dict[str, str]] = {}
        self.where: dict[str, str | None] = {}
        self.connections: list[tuple[str, str, str | None]] = []
        self.records: list[tuple[str, str | None]] = []
        self.stops: list[tuple[StopSpec, str | None]] = []
        self.opened: list[tuple[str, str | None]] = []
        self._handles: list[tuple[PortHandle, str | None]] = []
        self._resources: dict | None = None     # bindings already made (an assembly's components)
        self._integrator = None
        self.settings = SimSpec()
        self.sim(dt=dt, duration=duration, integrator=integrator, record_rate=record_rate, t0=t0, realtime=realtime)

    # -- what the simulation holds -------------------------------------------------------------------
    def sim(self, **settings) -> Builder:
        """Change sim settings: dt, duration, integrator, record_rate, t0, realtime."""
        integ = settings.get("integrator")
        if integ is not None and hasattr(integ, "advance"):         # an integrator object
            self._integrator = integ
            settings["integrator"] = {"name": integ.name, "params": integ.p.model_dump(mode="json")}
        elif integ is not None:
            self._integrator = None
            if isinstance(integ, IntegratorSpec):
                settings["integrator"] = integ.model_dump()
        data = {**self.settings.model_dump(), **settings}
        where = _caller()
        self.settings = _validate(SimSpec, data, lambda loc: where, "sim")
        return self

    def add(self, component: Component, *more: Component, uses: dict | None = None):
        """Add components (objects); returns the one added, or a tuple of them. ``uses``: {slot:
        provider (its name or object)} when several components provide what it uses."""
        where = _caller()
        for c in (component, *more):
            if not isinstance(c, Component):
                raise BuildError(f"add() takes component objects, got {type(c).__name__} ({where}); "
                                 "make one with its class: Pendulum('pend', length=2.0)")
            name = str(c.name)
            if name in self.components:
                raise BuildError(f"component '{name}' added twice ({where}; also at {self.where[name]})"
                                 if self.components[name] is c else
                                 f"two components are named '{name}' ({where}; also at {self.where[name]})")
            if "." in name or " " in name or not name:
                raise BuildError(f"component name '{name}' may not be empty or contain '.' or spaces ({where})")
            if getattr(c, "_built_into", None) is not None:
                raise BuildError(f"component '{name}' is already part of a built simulation ({where}); a "
                                 "component belongs to one: make new objects for another build")
            self.components[name] = c
            self.where[name] = where
            if uses:
                self.uses[name] = {slot: getattr(p, "name", p) for slot, p in uses.items()}
        return component if not more else (component, *more)

    def _text(self, port, kind: str, where) -> str:
        if isinstance(port, PortHandle):
            self._handles.append((port, where))
            return port.ref
        if isinstance(port, str):
            return port.strip()
        raise BuildError(f"expected a port ({'comp.out.NAME' if kind == 'output' else 'comp.inp.NAME'}) or "
                         f"'component.port', got {type(port).__name__} ({where})")

    def connect(self, source, *targets) -> Builder:
        """source output -> each target input (``b.connect(robot.out.joint_q, pid.inp.q)``)."""
        where = _caller()
        if not targets:
            raise BuildError(f"connect() needs a source output and at least one target input ({where})")
        src = self._text(source, "output", where)
        for t in targets:
            self.connections.append((src, self._text(t, "input", where), where))
        return self

    def record(self, *ports) -> Builder:
        where = _caller()
        self.records += [(self._text(p, "output", where), where) for p in ports]
        return self

    def stop(self, port, *, index=None, above=None, below=None, abs_above=None, reason=None,
             outcome: str = "failure") -> Builder:
        """End the run when the port's value (elements ``index``) passes one bound; ``outcome``: what that
        means (``failure``, the default, or ``success``), as an assembly's ``stop:`` entry."""
        where = _caller()
        data = {"signal": self._text(port, "output", where), "index": index, "above": above, "below": below,
                "abs_above": abs_above, "reason": reason, "outcome": outcome}
        spec = _validate(StopSpec, {k: v for k, v in data.items() if v is not None}, lambda loc: where, "stop")
        if sum(v is not None for v in (spec.above, spec.below, spec.abs_above)) != 1:
            raise ConfigError("a stop condition needs exactly one of above, below, abs_above", where, "stop")
        self.stops.append((spec, where))
        return self

    def open(self, *inputs) -> Builder:
        """Declare inputs set from Python (``Simulation.set_input``): left unconnected, even if required."""
        where = _caller()
        self.opened += [(self._text(p, "input", where), where) for p in inputs]
        return self

    # -- the build -----------------------------------------------------------------------------------
    @classmethod
    def from_resolved(cls, resolved, registry, open_inputs=()) -> Builder:
        """An assembly (a :class:`~.assembly.Resolved` configuration) as builder calls: its components
        made from their types (with their resources, errors naming the file and key), then added,
        connected, recorded and stopped on with their file:line."""
        from .plan import _instantiate

        comps, resources = _instantiate(resolved, registry)
        b = cls.__new__(cls)
        b.registry = registry
        b.components, b.where = comps, dict(resolved.where)
        b.uses = {n: dict(s.uses) for n, s in resolved.components.items() if s.uses}
        b.connections, b.records, b.stops = list(resolved.connections), list(resolved.record), list(resolved.stop)
        b.opened, b._handles = list(open_inputs), []
        b._resources, b._integrator, b.settings = resources, None, resolved.sim
        return b

    def plan(self):
        """The compiled plan (the components are bound into it: a builder builds once)."""
        from .plan import bind_objects, compile_plan

        for h, where in self._handles:
            if self.components.get(h.component.name) is not h.component:
                raise BuildError(f"{h.ref} ({where}): component '{h.component.name}' was not added to this "
                                 f"builder; add it first: b.add({h.component.name})")
        for n, c in self.components.items():
            if getattr(c, "_built_into", None) is not None:
                raise BuildError(f"component '{n}' is already part of a built simulation; a component belongs "
                                 "to one: make new objects for another build")
        resources = self._resources
        if resources is None:
            resources = bind_objects(self.components, self.uses, self.where)
        s = self.settings
        plan = compile_plan(self.components, resources, self.connections, self.records, self.stops, s.dt,
                            s.record_rate, self.opened)
        for c in self.components.values():
            c._built_into = True
        return plan

    def integrator(self):
        if self._integrator is not None:
            return self._integrator
        from .registry import default_registry
        from .session import make_integrator

        if self.registry is None:
            self.registry = default_registry()
        return make_integrator(self.settings.integrator, self.registry)

    def build(self):
        """The :class:`~.simulation.Simulation`, at t0 with the outputs there computed."""
        from .simulation import Simulation

        plan = self.plan()
        return Simulation(plan, self.integrator(), self.settings)
