"""Run one component alone: fix inputs, read outputs and derivatives, step updates.

    h = Harness(Pendulum, {"length": 2.0})
    h.inputs.tau = 0.3
    h.outputs()["theta"], h.derivative(), h.update()

No assembly, registry or integrator involved (Drake's "fix input, evaluate
output" idiom).
"""

from __future__ import annotations

import numpy as np

from .binding import Cell, make_namespace, set_cache
from .component import Component
from .signals import Structured
from .wiring import port_infos


class _InputSetter:
    def __init__(self, harness):
        object.__setattr__(self, "_h", harness)

    def __setattr__(self, name, value):
        self._h.set_input(name, value)


class Harness:
    def __init__(self, component: Component | type[Component], params: dict | None = None,
                 rate: float | None = None, name: str = "component", uses: dict | None = None):
        """``uses``: the resources the component needs, e.g. ``{"robot": RobotModel.load(design="eels-1.0")}``."""
        if isinstance(component, type):
            component = component(name, params or {}, rate, uses=uses or {})
        self.c = component
        self.infos = port_infos(component)
        self._in, self._in_cells, self._out, self._out_cells = {}, {}, {}, {}
        for n, port in component.inputs.items():
            info = self.infos[n]
            if isinstance(info.signal, Structured):
                self._in_cells[n] = Cell(port.default)
            else:
                default = 0.0 if port.default is None else port.default
                shape = info.shape if info.shape is not None else np.shape(default)
                self._in[n] = np.array(np.broadcast_to(np.asarray(default, dtype=info.signal.dtype), shape))
        for n in component.outputs:
            info = self.infos[n]
            if isinstance(info.signal, Structured):
                self._out_cells[n] = Cell()
            else:
                self._out[n] = np.zeros(info.shape, dtype=info.signal.dtype)
        self.u = make_namespace(component.name, "inputs", self._in, self._in_cells)
        self.y = make_namespace(component.name, "outputs", self._out, self._out_cells)
        cs = component.continuous_state()
        self.x = None if cs is None else np.array(cs.x0, dtype=float).ravel()
        self.ndx = None if cs is None else cs.tangent_size
        xd = component.discrete_state()
        self.xd = None if xd is None else np.array(xd, dtype=float).ravel()
        self.inputs = _InputSetter(self)
        self._make_cache()

    def _make_cache(self) -> None:
        set_cache(self.u, self.c.make_cache(self.x if self.x is not None else self.xd, self.u, self.y))

    def set_input(self, name: str, value) -> None:
        if name in self._in_cells:
            self._in_cells[name].value = value
        elif name in self._in:
            buf = self._in[name]
            if self.infos[name].shape is None and np.shape(value) != buf.shape:
                buf = self._in[name] = np.array(value, dtype=buf.dtype)
                self.u = make_namespace(self.c.name, "inputs", self._in, self._in_cells)
                self._make_cache()
            else:
                buf[...] = value
        else:
            raise KeyError(f"{self.c.name} has no input '{name}'; inputs: {', '.join(self.c.inputs)}")

    def outputs(self, t: float = 0.0) -> dict:
        x = self.x if self.x is not None else self.xd
        groups = {port.calc for port in self.c.outputs.values()}
        for calc in sorted(groups, key=lambda g: (g is not None, g or "")):
            (getattr(self.c, calc) if calc else self.c.output)(t, x, self.u, self.y)
        out = {n: b.copy() for n, b in self._out.items()}
        out.update({n: c.value for n, c in self._out_cells.items()})
        return out

    def derivative(self, t: float = 0.0) -> np.ndarray:
        """dx/dt after the outputs, as in a simulation: derivative() may reuse what output() computed."""
        self.outputs(t)
        dx = np.zeros(self.ndx)
        self.c.derivative(t, self.x, self.u, dx)
        return dx

    def update(self, t: float = 0.0) -> np.ndarray:
        self.c.update(t, self.xd, self.u)
        return self.xd.copy()
