"""Compile a resolved assembly into a flat, preallocated execution plan.

Built once, by one step that takes everything a run needs (components and
their resources, connections, records, stop conditions, the record rate,
sinks): instances, port buffers (inputs alias upstream outputs), state
layout, a topological order of evaluation nodes, per-phase lists for the
multi-rate updates, the output groups sampled at their readers' ticks, and
the set of components to prune. The plan is frozen: nothing changes it after
:func:`build` returns. The step loop (:mod:`.simulator`) then only walks its
prebuilt tuples of ``(method, state view, inputs, outputs)``.

Evaluation nodes are (component, output group): the outputs without a
``calc`` method form one group computed by ``output()``, each ``calc`` port its
own. A node depends on the inputs its ports feed through, so a state-only
output never creates an algebraic loop.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np
from pydantic import ValidationError

from .paths import absolute_paths
from .assembly import Resolved
from .binding import Cell, make_namespace, set_cache
from .component import Component, StopFlag
from .errors import BuildError, ConfigError
from .rates import MAX_PHASES, lcm, period_of, phase_count
from .resources import ResourceBindingError, provider_order, resolve_uses
from .signals import Structured
from .stops import StopCondition, compile_stop
from .validation_errors import config_error
from .wiring import PortInfo, PortRef, check_compatible, parse_ref, port_infos


@dataclass(frozen=True)
class Node:
    comp: Component
    method: object
    ports: tuple[str, ...]
    deps: tuple[str, ...]          # inputs it feeds through
    period: int                    # base steps between evaluations (1 = every step)
    discrete: bool                 # held between ticks (rate set or sink)

    def label(self) -> str:
        return f"{self.comp.name}[{','.join(self.ports)}]"


@dataclass(frozen=True)
class StateSlice:
    comp: Component
    x: slice
    dx: slice
    second_order: int | None
    manifold: bool


@dataclass(frozen=True)
class Plan:
    components: dict[str, Component]
    pruned: tuple[str, ...]
    infos: dict[str, dict[str, PortInfo]]
    sources: dict[PortRef, PortRef]               # input -> upstream output
    out_buffers: dict[PortRef, object]            # ndarray or Cell
    nodes: tuple[Node, ...]                       # topological order
    minor: tuple[tuple, ...]                      # continuous-stage evaluation
    major: tuple[tuple[tuple, ...], ...]          # per phase
    updates: tuple[tuple[tuple, ...], ...]        # per phase
    derivs: tuple[tuple, ...]
    once: tuple[tuple, ...]                       # time-invariant components: made once, before the first step
    n_phases: int
    X: np.ndarray
    DX: np.ndarray
    XD: np.ndarray
    slices: tuple[StateSlice, ...]
    dslices: dict[str, slice]
    n_euclid_x: int
    stop_flag: StopFlag
    dt: float
    record_refs: tuple[PortRef, ...]              # recorded ports, in column order
    record_every: int                             # base steps between recorded rows
    stops: tuple[StopCondition, ...]
    used: frozenset                               # output ports something reads
    caches: dict = field(default_factory=dict)    # component -> what its make_cache() returned (its u.cache)
    report: dict = field(default_factory=dict)
    holds: tuple[tuple, ...] = ()                 # (component.hold, its inputs): gates called every base step
    edits: tuple[tuple, ...] = ()                 # (component.edit_state, its inputs): state-edit requesters
    checks: tuple[tuple, ...] = ()                # (component.check, its inputs): once-per-base-step guards
    io: dict = field(default_factory=dict)        # component -> (state view, inputs, outputs): for Jacobians
    open_inputs: dict = field(default_factory=dict)   # PortRef -> its own buffer: inputs set from outside

    # -- the continuous system the integrators see ------------------------------
    @property
    def nx(self) -> int:
        return self.X.size

    @property
    def ndx(self) -> int:
        return self.DX.size

    def f(self, t: float, X: np.ndarray) -> np.ndarray:
        """dX/dt (tangent space) at (t, X); returns the shared DX buffer."""
        if X is not self.X:
            np.copyto(self.X, X)
        for fn, x, u, y in self.minor:
            fn(t, x, u, y)
        for fn, x, u, dx in self.derivs:
            fn(t, x, u, dx)
        return self.DX

    def integrate(self, X: np.ndarray, dX: np.ndarray, out: np.ndarray) -> None:
        """out = X ⊕ dX: a vector add for Euclidean states, the component's own map on manifolds."""
        e = self.n_euclid_x
        np.add(X[:e], dX[:e], out=out[:e])
        for s in self._manifold:
            s.comp.integrate(X[s.x], dX[s.dx], out[s.x])

    def bind_integrate(self, X: np.ndarray, dX: np.ndarray, out: np.ndarray):
        """``integrate(X, dX, out)`` for buffers fixed for a run (an integrator's work arrays, the
        plan's X): a call without arguments, its views made once."""
        e = self.n_euclid_x
        xe, dxe, oe = X[:e], dX[:e], out[:e]
        # a component may bind its map to the views itself (``bind_integrate``: e.g. a compiled kernel)
        parts = tuple(s.comp.bind_integrate(X[s.x], dX[s.dx], out[s.x]) if hasattr(s.comp, "bind_integrate")
                      else functools.partial(s.comp.integrate, X[s.x], dX[s.dx], out[s.x]) for s in self._manifold)
        add = np.add

        def integrate():
            add(xe, dxe, out=oe)
            for fn in parts:
                fn()
        return integrate

    def dexp_inv(self, X0: np.ndarray, dX: np.ndarray, K: np.ndarray) -> None:
        """Munthe-Kaas correction of a stage derivative K taken at X0 ⊕ dX (manifold states only)."""
        for s in self._lie:
            s.comp.dexp_inv(X0[s.x], dX[s.dx], K[s.dx])

    def bind_dexp_inv(self, X0: np.ndarray, dX: np.ndarray, K: np.ndarray):
        """``dexp_inv(X0, dX, K)`` for buffers fixed for a run: a call without arguments (as
        :meth:`bind_integrate`; a component's ``bind_dexp_inv`` is used where it has one)."""
        parts = tuple(s.comp.bind_dexp_inv(X0[s.x], dX[s.dx], K[s.dx]) if hasattr(s.comp, "bind_dexp_inv")
                      else functools.partial(s.comp.dexp_inv, X0[s.x], dX[s.dx], K[s.dx]) for s in self._lie)

        def dexp_inv():
            for fn in parts:
                fn()
        return dexp_inv

    def second_order_pairs(self) -> list[tuple[slice, slice]]:
        """(position-tangent slice, velocity slice) in DX for each [q, v] state."""
        pairs = []
        for s in self.slices:
            if s.second_order:
                nv = s.second_order
                start = s.dx.start
                pairs.append((slice(start, start + nv), slice(start + nv, start + 2 * nv)))
        return pairs

    def __post_init__(self):
        manifold = tuple(s for s in self.slices if s.manifold)
        object.__setattr__(self, "_manifold", manifold)
        object.__setattr__(self, "_lie", tuple(s for s in manifold
                                               if type(s.comp).dexp_inv is not Component.dexp_inv))

    def component_of_x(self, index: int) -> str:
        for s in self.slices:
            if s.x.start <= index < s.x.stop:
                return s.comp.name
        return "?"

    def component_of_xd(self, index: int) -> str:
        for name, sl in self.dslices.items():
            if sl.start <= index < sl.stop:
                return name
        return "?"


# -- helpers ---------------------------------------------------------------------

def _instantiate(resolved: Resolved, registry) -> tuple[dict[str, Component], dict]:
    """Components in definition order, built providers-first so each is handed the resources it uses;
    and the bindings ({user: {slot: provider}})."""
    classes = {}
    for name, spec in resolved.components.items():
        try:
            classes[name] = registry.component(spec.type)
        except Exception as e:
            raise ConfigError(str(e), resolved.where.get(name), f"components.{name}.type") from None
    order, binding = _resource_order(classes, {n: s.uses for n, s in resolved.components.items()}, resolved.where)
    built: dict[str, Component] = {}
    for name in order:
        spec, cls, where = resolved.components[name], classes[name], resolved.where.get(name)
        try:
            # relative file paths become absolute, from the file that named them (paths.py)
            built[name] = cls(name, absolute_paths(cls.Params, spec.params), spec.rate,
                              uses=resolve_uses(binding[name], built))
        except ValidationError as e:
            raise config_error(e, cls.Params, where=where, key_prefix=f"components.{name}.params",
                               unknown="parameter", owner=cls.__name__) from None
        except (ValueError, TypeError) as e:
            key = getattr(e, "key", None)         # a setup number error that found its parameter (component.py)
            raise ConfigError(str(e), where, f"components.{name}" + (f".params.{key}" if key else "")) from None
    return {n: built[n] for n in resolved.components}, _bound(binding)


def _bound(binding) -> dict:
    bound = {n: {slot: b[0] for slot, b in slots.items() if b is not None} for n, slots in binding.items()}
    return {n: b for n, b in bound.items() if b}


def _resource_order(classes: dict, explicit: dict, where: dict):
    """:func:`~.resources.provider_order`, its errors as a ConfigError naming the component's entry."""
    try:
        return provider_order(classes, explicit)
    except ResourceBindingError as e:
        raise ConfigError(str(e), where.get(e.component),
                          f"components.{e.component}.uses" if e.component else "components") from None


def bind_objects(comps: dict[str, Component], explicit: dict, where: dict) -> dict:
    """Components made as objects (a :class:`~.builder.Builder`): those made without the resources they
    need are handed them now from their providers, bound as an assembly binds them (by kind, or the
    provider ``explicit`` names), providers first; the bindings, as :func:`_instantiate` returns them."""
    classes = {}
    for n, c in comps.items():
        cls = type(c)
        if not c.pending_uses and cls.uses:      # given its resources at construction: it only offers
            cls = type(cls.__name__, (), {"uses": {}, "provides": cls.provides, "type_name": cls.type_name})
        classes[n] = cls
    order, binding = _resource_order(classes, explicit, where)
    for n in order:
        c = comps[n]
        if c.pending_uses:
            try:
                c.bind_resources(resolve_uses(binding[n], comps))
            except (ValueError, TypeError) as e:
                raise ConfigError(str(e), where.get(n), f"components.{n}") from None
    return _bound(binding)


def _cycle(nodes: list[Node], edges: dict[int, list[tuple[int, PortRef, PortRef]]]) -> str:
    """Find one cycle among ``nodes`` (indices in edges) and spell it as ports."""
    color, stack = {}, []

    def dfs(i):
        color[i] = 1
        stack.append(i)
        for j, src, dst in edges.get(i, ()):
            if color.get(j) == 1:
                k = stack.index(j)
                return stack[k:] + [j]
            if color.get(j) is None:
                r = dfs(j)
                if r:
                    return r
        color[i] = 2
        stack.pop()
        return None

    for i in range(len(nodes)):
        if color.get(i) is None:
            cyc = dfs(i)
            if cyc:
                parts = []
                for a, b in zip(cyc, cyc[1:]):
                    src, dst = next((s, d) for j, s, d in edges[a] if j == b)
                    parts.append(f"{src} -> {dst}")
                return " ; ".join(parts)
    return "?"


# -- the build, stage by stage ----------------------------------------------------

def _wire(connections, comps, infos, open_inputs=()) -> tuple[dict[PortRef, PortRef], frozenset]:
    """Parse and check every connection; return input -> upstream output, and the inputs declared open
    (``open_inputs``: (text, where) pairs; set from outside the plan, e.g. by a Python controller)."""
    sources: dict[PortRef, PortRef] = {}
    where_of: dict[PortRef, str] = {}
    opened = {}
    for text, where in open_inputs:
        ref = parse_ref(text, comps, "input", where)
        if isinstance(infos[ref.comp][ref.port].signal, Structured):
            raise BuildError(f"open input {ref} ({where}): only numeric inputs can be set from outside")
        opened[ref] = where
    for s, t, where in connections:
        src = parse_ref(s, comps, "output", where)
        dst = parse_ref(t, comps, "input", where)
        if dst in sources:
            raise BuildError(f"input {dst} is wired twice: from {sources[dst]} ({where_of[dst]}) and from {src} "
                             f"({where}); an input takes one source (add a sum block to combine)")
        if dst in opened:
            raise BuildError(f"input {dst} is declared open ({opened[dst]}) and wired from {src} ({where}); "
                             "an open input is set from outside: leave it unconnected")
        check_compatible(src, infos[src.comp][src.port], dst, infos[dst.comp][dst.port], where)
        sources[dst] = src
        where_of[dst] = where
    missing = [PortRef(n, i) for n, c in comps.items() for i, p in c.inputs.items()
               if p.required and PortRef(n, i) not in sources and PortRef(n, i) not in opened]
    if missing:
        lines = [f"  {m} ({comps[m.comp].type_name}, {infos[m.comp][m.port].describe()})" for m in missing]
        raise BuildError("required inputs are not connected:\n" + "\n".join(lines)
                         + "\nconnect each with 'source.output -> component.input'"
                         + " (or, from Python, declare it open: Builder.open)")
    return sources, frozenset(opened)


def _prune(comps, sources, roots: set[str]) -> list[str]:
    """Names of components none of whose outputs reach a root (state, sink, recorder, stop)."""
    upstream = defaultdict(set)
    for dst, src in sources.items():
        upstream[dst.comp].add(src.comp)
    needed, todo = set(roots), list(roots)
    while todo:
        for m in upstream[todo.pop()]:
            if m not in needed:
                needed.add(m)
                todo.append(m)
    return [n for n in comps if n not in needed]


def _bind(comps, infos, sources, stop_flag):
    """Allocate output buffers; inputs become read-only views of them (or own defaults)."""
    out_buffers: dict[PortRef, object] = {}
    for n, c in comps.items():
        for p in c.outputs:
            info = infos[n][p]
            out_buffers[PortRef(n, p)] = (Cell(None) if isinstance(info.signal, Structured)
                                          else np.zeros(info.shape, dtype=info.signal.dtype))
    u_of, y_of, own = {}, {}, {}
    for n, c in comps.items():
        numeric_in, cells_in = {}, {}
        for i, port in c.inputs.items():
            ref, info = PortRef(n, i), infos[n][i]
            if ref in sources:
                buf = out_buffers[sources[ref]]
            elif isinstance(info.signal, Structured):
                buf = Cell(port.default)
            else:
                default = 0.0 if port.default is None else port.default
                shape = info.shape if info.shape is not None else np.shape(default)
                buf = np.array(np.broadcast_to(np.asarray(default, dtype=info.signal.dtype), shape))
            if ref not in sources:
                own[ref] = buf          # its own value: the default, or what an open input is set to
            if isinstance(buf, Cell):
                cells_in[i] = buf
            else:
                view = buf.view()
                view.flags.writeable = False
                numeric_in[i] = view
        u_of[n] = make_namespace(n, "inputs", numeric_in, cells_in)
        mine = {p: out_buffers[PortRef(n, p)] for p in c.outputs}
        y_of[n] = make_namespace(n, "outputs", {p: b for p, b in mine.items() if not isinstance(b, Cell)},
                                 {p: b for p, b in mine.items() if isinstance(b, Cell)})
        c._stop = stop_flag
    return out_buffers, u_of, y_of, own


def _check_state_kinds(comps, cstates, dstates) -> None:
    for n, c in comps.items():
        cs, xd = cstates[n], dstates[n]
        if c.time_invariant and (c.inputs or cs is not None or xd is not None or c.rate is not None):
            raise BuildError(f"{n} ({c.type_name}) is declared time_invariant but has inputs, state or a rate")
        if cs is not None and xd is not None:
            raise BuildError(f"{n} ({c.type_name}) declares both continuous and discrete state; split it in two components")
        if cs is not None and c.rate is not None:
            raise BuildError(f"{n} ({c.type_name}) has continuous state and a rate; rates are for discrete components")
        if xd is not None and c.rate is None:
            raise BuildError(f"{n} ({c.type_name}) has discrete state and needs a rate (Hz) in the assembly")


def _layout_continuous(comps, cstates):
    """X and DX with one slice per component; Euclidean states first, so the
    integrator adds them in one vector operation."""
    specs = []
    for n, c in comps.items():
        cs = cstates[n]
        if cs is None:
            continue
        x0 = np.asarray(cs.x0, dtype=float).ravel()
        if not np.all(np.isfinite(x0)):
            raise BuildError(f"{n}: initial state is not finite: {x0}")
        specs.append((c.has_manifold_state() or cs.tangent_size != cs.nx, c, cs, x0))
    specs.sort(key=lambda s: s[0])  # stable: definition order kept within each kind
    X = np.zeros(sum(s[3].size for s in specs))
    DX = np.zeros(sum(s[2].tangent_size for s in specs))
    slices, x_of, dx_of = [], {}, {}
    ix = idx = n_euclid = 0
    for manifold, c, cs, x0 in specs:
        sx, sdx = slice(ix, ix + x0.size), slice(idx, idx + cs.tangent_size)
        X[sx] = x0
        x_of[c.name], dx_of[c.name] = X[sx], DX[sdx]
        slices.append(StateSlice(c, sx, sdx, cs.second_order, manifold))
        if not manifold:
            n_euclid = sx.stop
        ix, idx = sx.stop, sdx.stop
    return X, DX, slices, x_of, dx_of, n_euclid


def _layout_discrete(comps, dstates):
    parts = {n: np.asarray(dstates[n], dtype=float).ravel() for n in comps if dstates[n] is not None}
    XD = np.zeros(sum(v.size for v in parts.values()))
    dslices, xd_of, i0 = {}, {}, 0
    for n, v in parts.items():
        dslices[n] = slice(i0, i0 + v.size)
        XD[dslices[n]] = v
        xd_of[n] = XD[dslices[n]]
        i0 += v.size
    return XD, dslices, xd_of


def _nodes(comps, periods) -> tuple[list[Node], dict[PortRef, int]]:
    """One node per output group: the ports without ``calc``, and each ``calc`` port."""
    nodes: list[Node] = []
    node_of_port: dict[PortRef, int] = {}
    for n, c in comps.items():
        groups: dict[str | None, list[str]] = {}
        for p, port in c.outputs.items():
            groups.setdefault(port.calc, []).append(p)
        for calc, ports in groups.items():
            deps = sorted({d for p in ports for d in c.outputs[p].feedthrough_inputs(list(c.inputs))},
                          key=list(c.inputs).index)
            method = getattr(c, calc) if calc else c.output
            for p in ports:
                node_of_port[PortRef(n, p)] = len(nodes)
            nodes.append(Node(c, method, tuple(ports), tuple(deps), periods[n], c.rate is not None or c.is_sink))
    return nodes, node_of_port


def _topological_order(nodes, node_of_port, sources) -> list[int]:
    """Kahn's algorithm over feedthrough edges (deterministic); a leftover cycle is an algebraic loop."""
    edges: dict[int, list] = defaultdict(list)
    indeg = [0] * len(nodes)
    for j, node in enumerate(nodes):
        for d in node.deps:
            ref = PortRef(node.comp.name, d)
            if ref in sources:
                edges[node_of_port[sources[ref]]].append((j, sources[ref], ref))
                indeg[j] += 1
    ready = [j for j in range(len(nodes)) if indeg[j] == 0]
    order = []
    while ready:
        ready.sort()
        i = ready.pop(0)
        order.append(i)
        for j, _, _ in edges.get(i, ()):
            indeg[j] -= 1
            if indeg[j] == 0:
                ready.append(j)
    if len(order) < len(nodes):
        done = set(order)
        rest = [i for i in range(len(nodes)) if i not in done]
        remap = {i: k for k, i in enumerate(rest)}
        sub = {remap[i]: [(remap[j], s, d) for j, s, d in edges.get(i, ()) if j in remap] for i in rest}
        raise BuildError(f"algebraic loop (each output feeds through to the next): {_cycle([nodes[i] for i in rest], sub)}\n"
                         "break it with a component whose output depends only on its state (a delay, a filter)")
    return order


def _continuous_closure(slices, nodes, node_of_port, sources) -> set[int]:
    """Nodes the continuous derivatives depend on, through feedthrough; discrete ones are held.

    A stateful component's own ``output()`` group always joins, so ``derivative`` can rely on
    ``output`` having run on the same (t, x, u) and reuse what it computed (Drake's cache idea).
    """
    minor: set[int] = set()
    todo = [PortRef(s.comp.name, i) for s in slices for i in s.comp.inputs]
    stateful = {id(s.comp) for s in slices}
    for j, node in enumerate(nodes):
        if id(node.comp) in stateful and node.method == node.comp.output:
            minor.add(j)
            todo.extend(PortRef(node.comp.name, d) for d in node.deps)
    seen = set()
    while todo:
        ref = todo.pop()
        if ref in seen or ref not in sources:
            continue
        seen.add(ref)
        j = node_of_port[sources[ref]]
        if nodes[j].discrete or j in minor:
            continue
        minor.add(j)
        todo.extend(PortRef(nodes[j].comp.name, d) for d in nodes[j].deps)
    return minor


def _evaluated(node: Node, used) -> bool:
    """A ``calc`` port group is pure by contract: skipped when none of its ports is read.
    ``output()`` always runs (it may have side effects such as ``stop``)."""
    return node.method == node.comp.output or any(PortRef(node.comp.name, p) in used for p in node.ports)


def _sampled_periods(nodes, comps, sources, recorded, stopped, record_every: int, periods: dict, dt: float,
                     n_phases: int) -> dict[int, int]:
    """A ``calc`` group read only by sampling readers runs only when one of them reads.

    Readers that sample: discrete components (a rate), sinks, and the recorder
    (every ``record_every`` steps). If every reader of a group samples, the group
    runs every g steps, g the gcd of their periods: each reader then sees a fresh
    value, and nobody can observe the held one in between (the viewer reading a
    contact set at 30 Hz, the recorder reading a pose at 50 Hz). Groups a stop
    condition tests, or a continuous component reads, keep running every step.
    Returns {node index: period}; none if the extra patterns would pass MAX_PHASES.
    """
    readers: dict[PortRef, list[int]] = defaultdict(list)
    for dst, src in sources.items():
        c = comps[dst.comp]
        readers[src].append(periods[dst.comp] if c.rate else 1 if c.is_sink else 0)
    for ref in recorded:
        readers[ref].append(record_every)
    stop = set(stopped)
    sampled = {}
    for j, node in enumerate(nodes):
        if node.method == node.comp.output or node.period != 1:
            continue
        refs = [PortRef(node.comp.name, p) for p in node.ports]
        seen = [p for r in refs for p in readers.get(r, ())]
        if not seen or 0 in seen or any(r in stop for r in refs):
            continue                       # unread, read every stage, or stop-tested
        g = 0
        for p in seen:
            g = math.gcd(g, p)
        if g > 1:
            sampled[j] = g
    return sampled if lcm([n_phases, *sampled.values()]) <= MAX_PHASES else {}


def _major_lists(calls, n_phases, used) -> tuple[tuple[tuple, ...], ...]:
    return tuple(tuple(call for node, call in calls
                       if phase % node.period == 0 and _evaluated(node, used) and not node.comp.time_invariant)
                 for phase in range(n_phases))


def build(resolved: Resolved, registry, open_inputs=()) -> Plan:
    """Everything a run needs, decided once: the returned plan is never changed afterwards.
    ``open_inputs``: (``component.input``, where) pairs left unconnected, set from outside."""
    comps, resources = _instantiate(resolved, registry)
    return compile_plan(comps, resources, resolved.connections, resolved.record, resolved.stop,
                        resolved.sim.dt, resolved.sim.record_rate, open_inputs)


def compile_plan(comps: dict[str, Component], resources: dict, connections, record, stop, dt: float,
                 record_rate: float | None, open_inputs=()) -> Plan:
    """The plan of built components (an assembly's, :func:`build`; a builder's objects): connections
    as (source, target, where), records as (port, where), stops as (StopSpec, where); the same checks
    and errors whichever front end wrote them."""
    infos = {name: port_infos(c) for name, c in comps.items()}
    sources, opened = _wire(connections, comps, infos, open_inputs)
    recorded = [parse_ref(r, comps, "output", w) for r, w in record]
    for ref, (_, w) in zip(recorded, record):
        if isinstance(infos[ref.comp][ref.port].signal, Structured):
            raise BuildError(f"record {ref} ({w}): only numeric ports can be recorded")
    stop_refs = [(spec, parse_ref(spec.signal, comps, "output", w), w) for spec, w in stop]
    stopped = [ref for _, ref, _ in stop_refs]
    record_every = period_of(record_rate, dt, "sim.record_rate")

    cstates = {n: c.continuous_state() for n, c in comps.items()}
    dstates = {n: c.discrete_state() for n, c in comps.items()}
    roots = {n for n, c in comps.items()
             if c.is_sink or c.has_hold() or c.has_edit_state() or c.has_check() or cstates[n] is not None
             or dstates[n] is not None}
    roots |= {r.comp for r in recorded + stopped}
    pruned = _prune(comps, sources, roots)
    comps = {n: c for n, c in comps.items() if n not in pruned}
    sources = {d: s for d, s in sources.items() if d.comp in comps}

    stop_flag = StopFlag()
    out_buffers, u_of, y_of, own_inputs = _bind(comps, infos, sources, stop_flag)
    _check_state_kinds(comps, cstates, dstates)
    X, DX, slices, x_of, dx_of, n_euclid = _layout_continuous(comps, cstates)
    XD, dslices, xd_of = _layout_discrete(comps, dstates)

    periods = {n: period_of(c.rate, dt, f"{n}: rate") for n, c in comps.items()}
    nodes, node_of_port = _nodes(comps, periods)
    order = _topological_order(nodes, node_of_port, sources)
    minor_set = _continuous_closure(slices, nodes, node_of_port, sources)
    n_phases = phase_count(list(periods.values()))
    sampled = _sampled_periods(nodes, comps, sources, recorded, stopped, record_every, periods, dt, n_phases)
    nodes = [dataclasses.replace(nd, period=sampled[j]) if j in sampled else nd for j, nd in enumerate(nodes)]
    n_phases = lcm([n_phases, *sampled.values()])

    def call(node: Node):
        n = node.comp.name
        return (node.method, x_of.get(n, xd_of.get(n)), u_of[n], y_of[n])

    used = frozenset(sources.values()) | frozenset(recorded) | frozenset(stopped)
    caches = {}
    for n, c in comps.items():
        c.bind_outputs(frozenset(p for p in c.outputs if PortRef(n, p) in used))
        caches[n] = c.make_cache(x_of.get(n, xd_of.get(n)), u_of[n], y_of[n])
        set_cache(u_of[n], caches[n])
    calls = [(nodes[i], call(nodes[i])) for i in order]
    minor = tuple(call(nodes[i]) for i in order if i in minor_set)
    major = _major_lists(calls, n_phases, used)
    once = tuple(c for node, c in calls if node.comp.time_invariant)
    update_comps = [c for n, c in comps.items() if dstates[n] is not None or c.is_sink]
    updates = tuple(tuple((c.update, xd_of.get(c.name), u_of[c.name]) for c in update_comps
                          if phase % periods[c.name] == 0) for phase in range(n_phases))
    holds = tuple((c.hold, u_of[n]) for n, c in comps.items() if c.has_hold())
    edits = tuple((c.edit_state, u_of[n]) for n, c in comps.items() if c.has_edit_state())
    checks = tuple((c.check, u_of[n]) for n, c in comps.items() if c.has_check())
    derivs = tuple((s.comp.derivative, x_of[s.comp.name], u_of[s.comp.name], dx_of[s.comp.name]) for s in slices)
    stops = tuple(cond for spec, ref, w in stop_refs for cond in compile_stop(spec, ref, out_buffers[ref], w))

    report = {
        "components": {n: {"type": c.type_name, "rate_hz": c.rate, "period_steps": periods[n],
                           "continuous_states": int(x_of[n].size) if n in x_of else 0,
                           "discrete_states": int(xd_of[n].size) if n in xd_of else 0}
                       for n, c in comps.items()},
        "pruned": pruned,
        "resources": {n: b for n, b in resources.items() if n in comps},
        "state_size": {"continuous": int(X.size), "tangent": int(DX.size), "discrete": int(XD.size)},
        "evaluation_order": [nodes[i].label() for i in order],
        "unread_outputs": sorted(f"{n}.{p}" for n, c in comps.items() for p in c.outputs if PortRef(n, p) not in used),
        "continuous_stage_order": [nodes[i].label() for i in order if i in minor_set],
        "rates_hz": sorted({c.rate for c in comps.values() if c.rate is not None}),
        "phases": n_phases,
        "connections": len(sources),
        "dt": dt,
    }
    if sampled:
        report["sampled_output_groups"] = {nodes[j].label(): g for j, g in sampled.items()}
    return Plan(components=comps, pruned=tuple(pruned), infos=infos, sources=sources, out_buffers=out_buffers,
                nodes=tuple(nodes[i] for i in order), minor=minor, major=major, updates=updates, derivs=derivs,
                once=once, n_phases=n_phases, X=X, DX=DX, XD=XD, slices=tuple(slices), dslices=dslices,
                n_euclid_x=n_euclid, stop_flag=stop_flag, dt=dt, record_refs=tuple(recorded),
                record_every=record_every, stops=stops, used=used, caches=caches, report=report, holds=holds,
                edits=edits, checks=checks, io={n: (x_of.get(n, xd_of.get(n)), u_of[n], y_of[n]) for n in comps},
                open_inputs={r: own_inputs[r] for r in opened if r in own_inputs})
