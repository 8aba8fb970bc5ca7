"""The component: parameters, ports, optional continuous or discrete state.

A component is a class with a frozen pydantic ``Params`` model, named once as
its type argument (``class Pid(Component[PidParams])`` sets ``Pid.Params``), ports
declared as class attributes (see :mod:`.ports`) and up to five methods::

    output(t, x, u, y)        write outputs into y's preallocated arrays
    continuous_state()        -> ContinuousState (initial value, layout) or None
    derivative(t, x, u, dx)   write dx/dt (tangent space) into dx
    discrete_state()          -> initial discrete state array or None
    update(t, xd, u)          advance the discrete state in place (at its rate)

and two optional step-loop hooks: ``hold(t, u)`` (a gate that may hold the
loop) and ``edit_state(t, u, edit)`` (requests to change the state between
steps, :mod:`.state_edit`).

``x`` is the component's slice of the state the simulator owns (Drake's
Context idea): the component object keeps parameters and derived constants
only, so one instance can serve many runs. ``u`` reads inputs (zero-copy
views of the upstream outputs) and carries ``u.cache``, the per-run scratch
the framework made with ``make_cache()``; ``y`` holds the output buffers.
Build-time resources (the robot model) are declared with ``Uses`` and
``Provides`` (:mod:`.resources`) and bound before ``setup()``.
"""

from __future__ import annotations

import dataclasses
import types
from typing import Annotated, Any, ClassVar, Generic, Literal, TypeVar, Union, get_args, get_origin

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationInfo, field_validator

from .ports import Input, Output
from .resources import Provides, Uses


class Params(BaseModel):
    """Base of every component's parameters: frozen, unknown keys rejected, every float finite
    (NaN and ±inf refused, in nested lists, tuples and dicts too; a nested model is finite when it
    derives from Params as well) and no boolean where a number is meant (``true`` is not 1).

    A field that really means "unbounded" says so with ``None`` (preferred) or opts in with
    ``Field(allow_inf_nan=True)``.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    @field_validator("*", mode="before")
    @classmethod
    def _no_bool_for_number(cls, value, info: ValidationInfo):
        field = cls.model_fields.get(info.field_name) if info.field_name else None
        if field is not None:
            _refuse_bool(field.annotation, value)
        return value


def _refuse_bool(annotation, value) -> None:
    """Raise when ``value`` holds a bool where ``annotation`` wants a number (pydantic's lax mode
    reads true as 1): in the value itself or in the items of a list or tuple of numbers."""
    if isinstance(value, bool):
        if _wants_number(annotation) and not _admits_bool(annotation):
            raise ValueError(f"{str(value).lower()} is a boolean; a number is expected here")
        return
    if isinstance(value, (list, tuple)) and value:
        for arg in _members(annotation):
            origin = get_origin(arg)
            if origin in (list, tuple, set, frozenset):
                items = [a for a in get_args(arg) if a is not Ellipsis]
                if items and all(_wants_number(a) and not _admits_bool(a) for a in items):
                    for i, v in enumerate(value):
                        if isinstance(v, bool):
                            raise ValueError(f"item {i} is {str(v).lower()}, a boolean; a number is expected here")
                    return


def _members(annotation) -> tuple:
    """The members of a union (``X | None``), or the annotation itself (Annotated unwrapped)."""
    if get_origin(annotation) is Annotated:
        return _members(get_args(annotation)[0])
    if get_origin(annotation) in (Union, types.UnionType):
        return tuple(m for a in get_args(annotation) for m in _members(a))
    return (annotation,)


def _wants_number(annotation) -> bool:
    return any(m in (int, float) for m in _members(annotation))


def _admits_bool(annotation) -> bool:
    return any(m is bool or m is Any or (get_origin(m) is Literal and any(isinstance(a, bool) for a in get_args(m)))
               for m in _members(annotation))


P = TypeVar("P", bound=BaseModel)


@dataclasses.dataclass(frozen=True)
class ContinuousState:
    """Initial continuous state and its layout.

    x0:           initial value, shape (nx,)
    ndx:          size of the tangent space (derivatives, increments); differs
                  from nx on manifolds (a quaternion has 4 coordinates, 3 rates)
    second_order: nv when the state is [q, v] with dq (in the tangent space)
                  equal to v: the semi-implicit Euler integrator needs this split
    names:        element names for recording, len nx
    """

    x0: np.ndarray
    ndx: int | None = None
    second_order: int | None = None
    names: tuple[str, ...] | None = None

    @property
    def nx(self) -> int:
        return int(np.asarray(self.x0).size)

    @property
    def tangent_size(self) -> int:
        return self.nx if self.ndx is None else int(self.ndx)


class StopFlag:
    """Shared, mutable: a component asks the run to end by setting a reason, with the stop's outcome
    (``success`` | ``failure``) and, for a failure, its kind (:mod:`.outcomes`)."""

    __slots__ = ("reason", "source", "outcome", "kind")

    def __init__(self):
        self.clear()

    def clear(self) -> None:
        self.reason: str | None = None
        self.source: str | None = None
        self.outcome: str | None = None
        self.kind: str | None = None

    def set(self, reason: str, source: str, outcome: str, kind: str | None) -> None:
        """The first request wins (later ones in the same step are ignored)."""
        if self.reason is None:
            self.reason, self.source, self.outcome, self.kind = reason, source, outcome, kind


def _set_params(cls) -> None:
    """``cls.Params`` from the type argument (``class Pid(Component[PidParams])``), so the type is said
    once; an explicit ``Params = X`` still works, and must then be the type argument when both are given."""
    given = vars(cls).get("Params")
    argument = _params_argument(cls)
    if argument is None:
        return
    if given is not None and given is not argument:
        raise TypeError(f"{cls.__name__}: Params = {getattr(given, '__name__', given)} differs from the type "
                        f"argument {argument.__name__}; say it once, as Component[{argument.__name__}]")
    cls.Params = argument


def _params_argument(cls) -> type[BaseModel] | None:
    """The parameters model among the type arguments of ``cls``'s own generic Component bases."""
    for base in vars(cls).get("__orig_bases__", ()):
        origin = get_origin(base)
        if isinstance(origin, type) and issubclass(origin, Component):
            found = [a for a in get_args(base) if isinstance(a, type) and issubclass(a, BaseModel)]
            if len(found) == 1:
                return found[0]
    return None


class SetupNumberError(ValueError):
    """``setup()`` computed a number out of range (overflow, division by zero, an invalid operation):
    the message names the component and, where one stands out, the parameter (``key``: its dotted
    path under ``params``) and its value."""

    #: a parameter this far from 1 (|log10|x|| over this) is the likely cause: its square overflows
    EXTREME = 100

    def __init__(self, message: str, key: str | None = None):
        super().__init__(message)
        self.key = key

    @classmethod
    def of(cls, comp: "Component", e: BaseException) -> "SetupNumberError":
        what = f"{type(e).__name__}: {e}"
        found = [(k, v) for k, v in _numbers(comp.p.model_dump()) if v != 0 and (
            not np.isfinite(v) or abs(np.log10(abs(v))) > cls.EXTREME)]
        if len(found) == 1:
            k, v = found[0]
            return cls(f"{comp.name}: parameter {k} = {v!r} is out of range for {type(comp).__name__}'s setup "
                       f"({what}); valid: a magnitude between 1e-{cls.EXTREME} and 1e{cls.EXTREME} "
                       "(its square and products must fit a double)", k)
        if found:
            listing = ", ".join(f"{k} = {v!r}" for k, v in found)
            return cls(f"{comp.name}: setup of {type(comp).__name__} failed on a number out of range ({what}); "
                       f"parameters out of range: {listing}; valid: magnitudes between 1e-{cls.EXTREME} and "
                       f"1e{cls.EXTREME}")
        return cls(f"{comp.name}: setup of {type(comp).__name__} failed on a number out of range ({what}); "
                   "check its parameters' magnitudes")


def _numbers(obj, prefix: str = ""):
    """(dotted key, float) for every number in a params dump (nested mappings and lists included)."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _numbers(v, f"{prefix}{k}.")
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            yield from _numbers(v, f"{prefix}{i}.")
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool):
        yield prefix[:-1], float(obj)


class Component(Generic[P]):
    Params: ClassVar[type[BaseModel]] = Params
    #: registry name, e.g. "pendulum"; set by the registry if left empty
    type_name: ClassVar[str] = ""
    #: sinks (recorders, viewers, publishers) keep their upstream alive when pruning
    is_sink: ClassVar[bool] = False
    #: outputs depend on parameters only (no inputs, no state): computed once per run
    time_invariant: ClassVar[bool] = False
    inputs: ClassVar[dict[str, Input]] = {}
    outputs: ClassVar[dict[str, Output]] = {}
    #: build-time resources (see :mod:`.resources`): needed from others / built for others
    uses: ClassVar[dict[str, Uses]] = {}
    provides: ClassVar[dict[str, Provides]] = {}

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        _set_params(cls)
        ins, outs, uses, provides = {}, {}, {}, {}
        for klass in reversed(cls.__mro__):
            for name, attr in vars(klass).items():
                if isinstance(attr, Input):
                    ins[name] = attr
                elif isinstance(attr, Output):
                    outs[name] = attr
                elif isinstance(attr, Uses):
                    uses[name] = attr
                elif isinstance(attr, Provides):
                    provides[name] = attr
        cls.inputs, cls.outputs, cls.uses, cls.provides = ins, outs, uses, provides
        if "cache" in ins:
            raise TypeError(f"{cls.__name__}: 'cache' is reserved for u.cache; name the input otherwise")
        for name, port in outs.items():
            if port.calc is not None and not callable(getattr(cls, port.calc, None)):
                raise TypeError(f"{cls.__name__}.{name}: calc method '{port.calc}' is not defined")
            bad = [i for i in port.feedthrough_inputs(list(ins)) if i not in ins]
            if bad:
                raise TypeError(f"{cls.__name__}.{name}: feedthrough names unknown inputs {bad}")

    def __init__(self, name: str = "component", params: P | dict | None = None, rate: float | None = None,
                 uses: dict | None = None, **param_values):
        """``params`` a ``Params`` instance or a dict, or the parameters as keywords
        (``Pendulum("pend", length=2.0)``). ``uses``: the resources it needs; left out (None) while a
        required one is missing, construction waits for a :class:`~.builder.Builder` to bind them
        from the components that provide them, as an assembly does (``setup()`` runs then)."""
        self.name = name
        if param_values:
            if params is None or isinstance(params, dict):
                params = {**(params or {}), **param_values}
            else:
                raise TypeError(f"{name}: give the parameters as a Params instance or as keywords, not both")
        if params is None:
            params = {}
        self.p: P = params if isinstance(params, self.Params) else self.Params(**params)
        if rate is not None and rate <= 0:
            raise ValueError(f"{name}: rate must be > 0 Hz, got {rate}")
        self.rate = rate
        self._stop = StopFlag()
        self.used_outputs: frozenset[str] = frozenset(type(self).outputs)
        if uses is None and any(u.required for u in type(self).uses.values()):
            self.pending_uses = True          # a builder binds them (bind_resources), then setup() runs
            return
        self.bind_resources(uses or {})

    #: True while a required resource waits to be bound by a builder (setup() not run yet)
    pending_uses: bool = False

    def bind_resources(self, uses: dict) -> None:
        """Bind the resources (``{slot: object}``) and run ``setup()``: at construction, or later for a
        component made without its resources (a :class:`~.builder.Builder` binds them at build)."""
        self._bind_uses(uses)
        try:
            with np.errstate(over="raise"):      # an overflow in setup is an error there, not an inf later
                self.setup()
        except (OverflowError, FloatingPointError, ZeroDivisionError, RuntimeWarning) as e:
            raise SetupNumberError.of(self, e) from e
        self.pending_uses = False
        for slot, prov in type(self).provides.items():
            obj = self.__dict__.get(slot)
            if not isinstance(obj, prov.kind):
                raise TypeError(f"{self.name}: setup() must set self.{slot} to a {prov.kind.__name__} "
                                f"(it provides one), got {type(obj).__name__}")

    @property
    def out(self):
        """Its output ports as attributes (``pend.out.theta``): what a builder connects, records and
        stops on, and what a simulation reads."""
        from .ports import PortNamespace
        return PortNamespace(self, "output")

    @property
    def inp(self):
        """Its input ports as attributes (``damper.inp.omega``): what a builder connects or opens."""
        from .ports import PortNamespace
        return PortNamespace(self, "input")

    def _bind_uses(self, given: dict) -> None:
        cls = type(self)
        unknown = [k for k in given if k not in cls.uses]
        if unknown:
            raise ValueError(f"{self.name}: given resource '{unknown[0]}', which it does not use; "
                             f"it uses: {', '.join(cls.uses) or 'nothing'}")
        for slot, use in cls.uses.items():
            obj = given.get(slot)
            if obj is None and use.required:
                raise ValueError(f"{self.name}: needs a {use.kind.__name__} ('{slot}'); in an assembly the "
                                 f"component that provides one binds it, alone pass uses={{'{slot}': ...}}")
            if obj is not None and not isinstance(obj, use.kind):
                raise TypeError(f"{self.name}: '{slot}' must be a {use.kind.__name__}, got {type(obj).__name__}")
            setattr(self, slot, obj)

    # -- hooks a component overrides ------------------------------------------
    def setup(self) -> None:
        """Derive constants from ``self.p`` (called once, after validation).

        A component whose port count depends on its params (a recorder or viewer
        taking N signals) may extend its ports here by assigning new dicts to
        ``self.inputs`` / ``self.outputs`` (class ports plus ``Input``/``Output``
        instances with ``name`` set); the build reads the instance's ports.
        """

    def continuous_state(self) -> ContinuousState | None:
        return None

    def discrete_state(self) -> np.ndarray | None:
        return None

    def output(self, t: float, x, u, y) -> None:
        """Compute the outputs that have no ``calc`` method of their own."""

    def bind_outputs(self, used: frozenset[str]) -> None:
        """Told at build which output ports anything reads (connected, recorded, stop-tested).

        The plan skips a ``calc`` port group nobody reads; ``output()`` is
        always called (it may have side effects, e.g. ``stop``), so a
        component with costly outputs there may test ``self.used_outputs``
        and skip them. Until a build calls this (a Harness), every output is used.
        """
        self.used_outputs = used

    def make_cache(self, x, u, y):
        """This run's scratch and precomputed kernel arguments (Drake's cache entries), or None.

        Called by the build once, after ports are bound and ``bind_outputs``, with
        this plan's state view ``x`` (None without state), inputs ``u`` and output
        buffers ``y``: arrays there are never reallocated, so a kernel's argument
        record can hold views of them. Every method then finds the result as
        ``u.cache`` (a session as ``plan.caches[name]``). The component object
        itself keeps parameters and constants.
        """
        return None

    def derivative(self, t: float, x, u, dx) -> None:
        """dx/dt into ``dx``. Always called after ``output()`` on the same (t, x, u), so it may
        reuse what ``output()`` computed."""
        raise NotImplementedError(f"{type(self).__name__} declares continuous state but no derivative()")

    def update(self, t: float, xd, u) -> None:
        raise NotImplementedError(f"{type(self).__name__} declares discrete state but no update()")

    def add_inputs(self, ports: dict) -> None:
        """Per-instance inputs, made in ``setup()`` from the params (a sink's one input per signal or
        sensor it reads): named by their keys, added to the class's ports for this instance only."""
        for name, port in ports.items():
            port.name = name
        self.inputs = {**type(self).inputs, **ports}

    def before_run(self, t0: float, u) -> None:
        """Optional: once before a run's first step, outside its timed loop (``Session.run``, a
        ``Simulation``'s first advance; never ``snakesim check``): open what the first step would
        otherwise open (a DDS participant and its endpoints, a recording file), so the run's wall time
        and real-time factor measure the run. ``t0``: the run's start time, s; ``u``: its inputs, with
        ``u.cache``."""

    def after_run(self, u) -> None:
        """Optional: once after a run's last step, whatever ended it: close what :meth:`before_run` (or
        the first step) opened, so files are complete when the run returns and a next run opens afresh."""

    def hold(self, t: float, u) -> None:
        """Optional: called once per base step, after the discrete updates of tick t and before the
        integrator advances past t; it may block (a gate that holds the step loop: pause, single
        steps, lockstep with an external controller). A component that overrides it is never pruned
        and should bound its wait (a timeout that calls :meth:`stop`). Not called at the last tick."""

    @classmethod
    def has_hold(cls) -> bool:
        return cls.hold is not Component.hold

    def check(self, t: float, u, restart: bool) -> None:
        """Optional: a once-per-base-step guard. Called at every base tick t after that tick's outputs
        are computed and recorded and before the stop conditions are tested, never inside an
        integrator's stages; it may compare the state at t with what it kept from the previous tick and
        call :meth:`stop`. ``restart`` is True at the first tick of a run and at the tick after a state
        edit (no previous tick to compare with). Enabled per instance by :meth:`has_check`; a component
        that has one is never pruned."""

    def has_check(self) -> bool:
        """Whether the simulator calls :meth:`check` (an instance's choice: a guard may be switched off
        by a parameter, and then costs nothing)."""
        return type(self).check is not Component.check

    def edit_state(self, t: float, u, edit) -> None:
        """Optional: called once per base step right after the gates (``hold``), before the integrator
        advances past t; it may request state changes through ``edit`` (a
        :class:`~snakesim.framework.state_edit.StateEdit`: ``reset()``, ``write(component, index, values)``),
        which the simulator applies as the state at t + dt (see :mod:`~snakesim.framework.state_edit`).
        A component that overrides it is never pruned. Not called at the last tick."""

    @classmethod
    def has_edit_state(cls) -> bool:
        return cls.edit_state is not Component.edit_state

    def integrate(self, x: np.ndarray, dx: np.ndarray, out: np.ndarray) -> None:
        """out = x ⊕ dx on the state's manifold; Euclidean by default."""
        np.add(x, dx, out=out)

    def dexp_inv(self, x0: np.ndarray, u: np.ndarray, k: np.ndarray) -> None:
        """Map ``k``, a derivative evaluated at x0 ⊕ u, to the chart at x0, in place.

        Multi-stage integrators combine stage derivatives in the chart at the
        step's start (Munthe-Kaas RK); on a non-commutative manifold (SE(3))
        they keep their order only with this correction. Identity by default.
        """

    # -- derivatives for linearly implicit integrators (all optional; see framework/linearization.py) ----
    def port_jacobian(self, port: str, t: float, x, u, y):
        """The derivative of output ``port`` w.r.t. this component's state and inputs at its last
        evaluation: a :class:`~.linearization.Selection`, an :class:`~.linearization.Elementwise`,
        an object its reader understands, or None (undeclared: left out of the Jacobian)."""
        return None

    def state_jacobian(self, t: float, x, u, y):
        """First-order continuous state: an :class:`~.linearization.Elementwise` over dx/dt (rows)
        and the inputs / own state (``"x"``), or None (undeclared)."""
        return None

    def mechanical_jacobian(self, t: float, x, u, y, lin):
        """Second-order continuous state [q, v]: a :class:`~.linearization.Mechanical` block (mass
        matrix and generalised-force derivatives), asking ``lin`` for its inputs' derivatives."""
        return None

    def stiffness_hint(self, u, readers) -> list[tuple[float, str]]:
        """The stiffest modes this component sets, as (ω in rad/s, what) pairs, checked once before the
        first step against the integrator's stability bound (:mod:`.stiffness`); ``u`` its inputs (the
        time-invariant ones already computed), ``readers(port)`` the components reading one of its outputs."""
        return []

    def build_report(self, baseline: bool = False) -> dict | None:
        """Extra facts for ``snakesim check`` (e.g. a model optimisation), asked on demand. ``baseline``
        (``check --baseline``): also what costs extra models, memory or timing (the multibody's
        unoptimised baselines); without it the report builds nothing big."""
        return None

    # -- services ------------------------------------------------------------
    def stop(self, reason: str, outcome: str = "failure", kind: str | None = None) -> None:
        """End the run after this step with ``reason``.

        ``outcome``: ``"failure"`` (the default: a guard, a mobility failure) or ``"success"`` (the
        run did what it was for: an evaluation reaching its goal; ``snakesim run`` exits 0). A failure's
        ``kind`` is one of :data:`~.outcomes.FAILURE_KINDS` (default ``"guard"``); it picks the exit
        code and goes into the summary's ``failure_kind``."""
        from .outcomes import check_stop

        kind = check_stop(outcome, kind, "guard")     # a wrong outcome or kind is the caller's bug: raise
        self._stop.set(reason, self.name, outcome, kind)

    @classmethod
    def has_manifold_state(cls) -> bool:
        return cls.integrate is not Component.integrate

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r}>"
