"""Port declarations: class attributes of a component, named by the attribute.

    q   = Input(shape="n", unit="rad")
    tau = Output(shape="n", unit="N*m", feedthrough=("q_ref", "q"))

``role`` says what a port carries in its domain's vocabulary (an opaque
string to the framework, e.g. "link_poses" or "joint_positions"): sinks such
as a viewer or a ROS publisher find ports by role or structured type, never
by guessing from port names.

``may_be_nan`` (outputs) declares NaN a value of the port ("not defined yet"): the run's
non-finite checks of recorded and sink-read outputs let it through, never ±inf.

``feedthrough`` lists the inputs an output depends on directly (``True`` for
all, ``()`` for none: a function of state only). The scheduler orders
evaluations and rejects algebraic loops from it. ``calc`` names a method that
computes just this output; outputs without one are computed by the
component's ``output`` method. Splitting state-only outputs from feedthrough
ones (Drake's per-port calc) is what lets a controller read a body's state and
drive the same body without a false algebraic loop.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .signals import Numeric, ShapeSpec, Structured


class Port:
    kind = "port"

    def __init__(self, shape: ShapeSpec = (), *, unit: str | None = "1", dtype: Any = np.float64,
                 type: type | None = None, names=None, doc: str = "", role: str | None = None):
        self.signal = Structured(type) if type is not None else Numeric(shape, dtype, unit, names)
        self.doc = doc
        self.role = role
        self.name = "?"

    def __set_name__(self, owner, name):
        self.name = name

    @property
    def structured(self) -> bool:
        return isinstance(self.signal, Structured)

    def describe(self) -> str:
        sig = self.signal
        if self.structured:
            return sig.describe()
        shape = sig.shape if not callable(sig.shape) else "set at build"
        return f"{shape} [{sig.unit if sig.unit is not None else 'any'}]"


class Input(Port):
    """An input port. ``required=False`` inputs take ``default`` when unconnected."""

    kind = "input"

    def __init__(self, shape: ShapeSpec = (), *, unit: str | None = "1", dtype: Any = np.float64,
                 type: type | None = None, names=None, required: bool = True, default: Any = None,
                 doc: str = "", role: str | None = None):
        super().__init__(shape, unit=unit, dtype=dtype, type=type, names=names, doc=doc, role=role)
        self.required = required and default is None
        self.default = default


class Output(Port):
    """An output port with its direct-feedthrough declaration."""

    kind = "output"

    def __init__(self, shape: ShapeSpec = (), *, unit: str | None = "1", dtype: Any = np.float64,
                 type: type | None = None, names=None, feedthrough: bool | tuple[str, ...] = True,
                 calc: str | None = None, doc: str = "", role: str | None = None, may_be_nan: bool = False):
        super().__init__(shape, unit=unit, dtype=dtype, type=type, names=names, doc=doc, role=role)
        self.feedthrough = feedthrough
        self.calc = calc
        #: NaN is a value of this port, meaning "not defined (yet)" (a settle time before the latch, "no
        #: command"); the run's non-finite checks let NaN through here, never ±inf
        self.may_be_nan = may_be_nan

    def feedthrough_inputs(self, input_names: list[str]) -> tuple[str, ...]:
        if self.feedthrough is True:
            return tuple(input_names)
        if self.feedthrough is False:
            return ()
        return tuple(self.feedthrough)


class PortHandle:
    """One port of one component instance (``robot.out.joint_q``): what a
    :class:`~.builder.Builder` connects, records, stops on or opens, and what a
    :class:`~.simulation.Simulation` reads or sets. Checked at build with the assembly's errors."""

    __slots__ = ("component", "port", "kind")

    def __init__(self, component, port: str, kind: str):
        self.component, self.port, self.kind = component, port, kind

    @property
    def ref(self) -> str:
        """``component.port``, as an assembly writes it."""
        return f"{self.component.name}.{self.port}"

    def __repr__(self) -> str:
        return f"<{self.kind} {self.ref}>"

    def __str__(self) -> str:
        return self.ref


class PortNamespace:
    """A component instance's inputs or outputs as attributes, tab-completable (``dir()`` lists them).
    A name that is not a port is refused at once, with the ports it has."""

    __slots__ = ("_comp", "_kind")

    def __init__(self, comp, kind: str):
        object.__setattr__(self, "_comp", comp)
        object.__setattr__(self, "_kind", kind)

    def _ports(self) -> dict:
        c = self._comp
        return c.outputs if self._kind == "output" else c.inputs

    def __getattr__(self, name: str) -> PortHandle:
        if name.startswith("__"):
            raise AttributeError(name)
        ports = self._ports()
        if name not in ports and not getattr(self._comp, "pending_uses", False):
            import difflib
            close = difflib.get_close_matches(name, list(ports), n=3, cutoff=0.5)
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise AttributeError(f"{self._comp.name} ({type(self._comp).__name__}) has no {self._kind} '{name}'"
                                 f"{hint}; its {self._kind}s: {', '.join(ports) or 'none'}")
        return PortHandle(self._comp, name, self._kind)

    def __setattr__(self, name, value):
        raise AttributeError("ports are connected with a Builder, and open inputs set on a Simulation")

    def __dir__(self):
        return sorted(self._ports())

    def __iter__(self):
        return (PortHandle(self._comp, n, self._kind) for n in self._ports())

    def __repr__(self) -> str:
        return f"<{self._kind}s of {self._comp.name}: {', '.join(self._ports()) or 'none'}>"
