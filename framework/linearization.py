"""The system's Jacobian J = ∂f/∂X, assembled from what components declare, and the linear solve
(I − c·J) k = r that linearly implicit integrators (:mod:`.integrators.rosenbrock_w`) need.

Components declare derivatives; none is required. Three optional methods:

``port_jacobian(port, t, x, u, y)``
    the derivative of one output port with respect to the component's own state and inputs,
    evaluated at the point of its last ``output()`` (the integrator asks right after the plan's
    evaluation at the step's start). It returns one of

    - :class:`Selection`: the port copies coordinates of the component's tangent state
      (a multibody's joint angles and rates);
    - :class:`Elementwise`: each element depends on a few elements of inputs or of the state,
      with given coefficients (a PID, a joint spring-damper);
    - an object a particular reader understands (the contact's per-link wrench derivative,
      read by the multibody: :mod:`snakesim.components.multibody.linearization`);
    - ``None``: not declared. The reader then leaves the dependence out of J.

``state_jacobian(t, x, u, y)``
    a component with first-order continuous state: an :class:`Elementwise` whose rows are its
    tangent state's derivative, terms on its inputs and on its own state (``"x"``). Only the
    diagonal of its own block is kept (filters and integrals have nothing else).

``mechanical_jacobian(t, x, u, y, lin)``
    a component with a second-order state ``[q, v]`` (``q̇ = v`` in the tangent space, ``M v̇ =
    Q(q, v, ...)``): its :class:`Mechanical` block, the mass matrix M and the generalised-force
    derivatives ∂Q/∂q, ∂Q/∂v, and ∂Q/∂(other states) as a sparse matrix. It asks ``lin`` for
    the derivatives of its inputs (:meth:`Linearization.input_jacobian`,
    :meth:`Linearization.source_jacobian`). Undeclared (None), only ``q̇ = v`` enters J.

What is left out of J is treated explicitly by a W-method (its order does not depend on J, only
its stability does): a component that declares nothing costs stability, never accuracy. Couplings
between two second-order components and off-diagonal first-order terms are left out likewise.

The solve exploits the structure instead of factorising the (ndx × ndx) matrix. With the
first-order states F, a second-order owner's q, v and c = γh, (I − cJ) k = r reads::

    k_q − c k_v = r_q
    M k_v − c (G_q k_q + G_v k_v + G_F k_F) = M r_v
    k_F − c (d_F ∘ k_F + P_q k_q + P_v k_v) = r_F            (d_F the diagonal)

and eliminating k_q and k_F leaves one (nv × nv) system per owner::

    [M − c G_v − c² G_q − c² G_F D (P_v + c P_q)] k_v = M r_v + c G_q r_q + c G_F D (r_F + c P_q r_q)

with D = diag(1 / (1 − c d_F)). Dense (M, G_q, G_v given as matrices), its LU costs O(nv³) per
Jacobian (nv = 36 for ten EELS 1.0 modules, 306 for a hundred) and each solve O(nv²). An owner
may instead hand a ``structured`` operator (:class:`Mechanical`) that factorises and solves
M − c G_v − c² G_q + diag(e) itself (a multibody: on its link tree in O(links),
components/multibody/articulated_solve_kernels.py); the first-order share is then passed as the
diagonal e, and when it is not diagonal the owner's dense blocks are asked for instead.
"""

from __future__ import annotations

import functools
import operator
from dataclasses import dataclass

import numpy as np

from . import linear_solve_kernels as kern


@dataclass(frozen=True)
class Selection:
    """An output whose flat element i is the coordinate ``cols[i]`` of its component's tangent
    state (local index): ∂y_i/∂x = e_{cols[i]}."""

    cols: np.ndarray


@dataclass(frozen=True)
class Elementwise:
    """∂y/∂(inputs, state) as a few entries per output element.

    ``terms``: tuples ``(source, rows, index, coef)``: ∂y[rows[k]]/∂source[index[k]] = coef[k],
    flat indices; ``source`` an input port name or ``"x"`` (the component's own tangent state).
    Inputs not named do not affect y. ``size``: the number of output elements (rows)."""

    size: int
    terms: tuple[tuple[str, np.ndarray, np.ndarray, np.ndarray], ...]


@dataclass(frozen=True)
class Coo:
    """A sparse (n_rows × ndx) derivative as triplets; ``selection``: one entry of 1 per row, row i
    at column cols[i] (rows = arange)."""

    n_rows: int
    rows: np.ndarray
    cols: np.ndarray
    vals: np.ndarray
    selection: bool = False

    def matvec(self, x: np.ndarray, n: int) -> np.ndarray:
        """(this @ x) as a length-n vector (rows beyond n_rows are zero)."""
        return np.bincount(self.rows, weights=self.vals * x[self.cols], minlength=n)


def compose(rows, index, coef, sub: Coo) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triplets of T·sub, T the sparse matrix with entries T[rows[k], index[k]] = coef[k]."""
    if sub.selection:
        return rows, sub.cols[index], coef
    order = np.argsort(sub.rows, kind="stable")
    srow, scol, sval = sub.rows[order], sub.cols[order], sub.vals[order]
    ptr = np.searchsorted(srow, np.arange(sub.n_rows + 1))
    cnt = ptr[index + 1] - ptr[index]
    k = np.repeat(np.arange(index.size), cnt)
    m = np.repeat(ptr[index] - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
    return rows[k], scol[m], coef[k] * sval[m]


@dataclass
class Mechanical:
    """A second-order owner's block: M, ∂Q/∂q, ∂Q/∂v (nv × nv) and ∂Q/∂(other states) (``GF``,
    rows the owner's v, absolute tangent columns).

    ``structured`` (optional): an operator for the same M, G_q, G_v that the solve uses instead of a
    dense LU. Methods: ``factor(c, e) -> bool`` (factorise M − c G_v − c² G_q + diag(e); False if
    singular), ``solve_into(r, out, q0, c, extra)`` (k_v = (factorised)⁻¹ (M r_v + c G_q r_q +
    extra) into out[q0 + nv:], k_q = r_q + c k_v into out[q0:], r_q = r[q0:q0 + nv]) and
    ``dense() -> (M, Gq, Gv)``. With it, M, Gq and Gv may be None (:meth:`blocks` builds them)."""

    M: np.ndarray | None
    Gq: np.ndarray | None
    Gv: np.ndarray | None
    GF: Coo | None = None
    structured: object | None = None

    def blocks(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(M, Gq, Gv) as dense matrices (from the structured operator where not given)."""
        if self.M is None:
            self.M, self.Gq, self.Gv = self.structured.dense()
        return self.M, self.Gq, self.Gv


_EMPTY = Coo(0, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
_MISSING = object()


class Linearization:
    """J of a plan, assembled from the components' declarations at the current evaluation."""

    def __init__(self, plan):
        self.plan = plan
        self.ndx = plan.ndx
        self.io = plan.io                           # name -> (x, u, y)
        self.slices = {s.comp.name: s for s in plan.slices}
        self.owners = [s for s in plan.slices if s.second_order]
        self.first = [s for s in plan.slices if not s.second_order
                      and type(s.comp).state_jacobian is not _base("state_jacobian")]
        self._owned = np.zeros(self.ndx, dtype=bool)
        for s in plan.slices:
            if s.second_order:
                self._owned[s.dx] = True
        self.F = np.flatnonzero(~self._owned)      # first-order tangent indices
        self._sources = {(d.comp, d.port): (plan.components[u.comp], u.port) for d, u in plan.sources.items()}
        # (component name, input port) -> (upstream component, its port, its (x, u, y)): looked up once
        self._source_io = {k: (up, port, *self.io[up.name]) for k, (up, port) in self._sources.items()
                           if up.name in self.io}
        self.t = 0.0
        self._memo: dict = {}          # this assembly's answers
        self._memo_src: dict = {}      # this assembly's source_jacobian answers
        self._kept: dict = {}          # the last composition per input: reused while its declaration is the same object
        self.stats = {"assemblies": 0}
        self.gamma_hint = None         # the integrator's γ, for messages (c = γh)
        self._dinv_at = (None, None)   # (c, d) of the last Dinv
        self._dinvs: dict = {}         # c -> Dinv for the current d: a step-size ladder revisits a few c
        self._rhs: dict = {}           # q0 -> an owner's right-hand-side scratch (kept: bound solves read it)
        self._extra: dict = {}         # q0 -> an owner's first-order diagonal share (kept: operators bind to it)
        self._solve_key = None         # replaced when a factorisation changes what a bound solve holds
        self._solve_parts = None

    # -- what components ask ---------------------------------------------------------------------
    def source(self, comp, port: str):
        """(component, output port) driving ``comp``'s input ``port``, or None if unconnected."""
        return self._sources.get((comp.name, port))

    def source_jacobian(self, comp, port: str):
        """What the component driving ``comp.port`` declares for that output (``port_jacobian``),
        with that component; (None, None) when unconnected or undeclared."""
        key = (comp.name, port)
        got = self._memo_src.get(key)
        if got is None:
            src = self._source_io.get(key)
            if src is None:
                got = (None, None)
            else:
                up, out, x, u, y = src
                got = (up.port_jacobian(out, self.t, x, u, y), up)
            self._memo_src[key] = got
        return got

    def input_jacobian(self, comp, port: str) -> Coo | None:
        """∂(comp's input ``port``, flat)/∂X (tangent) composed through Selection and Elementwise
        declarations upstream; None if some link is undeclared."""
        key = ("in", comp.name, port)
        out = self._memo.get(key, _MISSING)
        if out is not _MISSING:
            return out
        obj, up = self.source_jacobian(comp, port)
        kept = self._kept.get(key)
        if kept is not None and kept[0] is obj and self._same_inputs(up, kept[2]):
            self._memo[key] = kept[1]                   # the same declaration over the same inputs
            return kept[1]
        out = None
        if isinstance(obj, Selection):
            n = obj.cols.size
            out = Coo(n, np.arange(n), self.slices[up.name].dx.start + obj.cols, np.ones(n), selection=True)
        elif isinstance(obj, Elementwise):
            out = self._compose(up, obj)
        self._memo[key] = out
        if obj is not None:
            deps = () if not isinstance(obj, Elementwise) else tuple(
                (src, self.input_jacobian(up, src)) for src in {t[0] for t in obj.terms if t[0] != "x"})
            self._kept[key] = (obj, out, deps)
        return out

    def _same_inputs(self, comp, deps) -> bool:
        """True if every (input port, composition) in ``deps`` is still what ``comp``'s input composes to."""
        for p, c in deps:
            if self.input_jacobian(comp, p) is not c:
                return False
        return True

    def _compose(self, comp, ew: Elementwise, skip_state: bool = False) -> Coo:
        R, C, V = [], [], []
        for source, rows, index, coef in ew.terms:
            if rows.size == 0:
                continue
            if source == "x":
                if not skip_state:
                    R.append(rows), C.append(self.slices[comp.name].dx.start + index), V.append(coef)
                continue
            sub = self.input_jacobian(comp, source)
            if sub is None:
                continue
            r, c, v = compose(rows, index, coef, sub)
            R.append(r), C.append(c), V.append(v)
        if not R:
            return Coo(ew.size, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
        return Coo(ew.size, np.concatenate(R), np.concatenate(C), np.concatenate(V))

    # -- assembly and solve ----------------------------------------------------------------------
    def assemble(self, t: float) -> None:
        """Ask every component for its derivatives at the plan's current evaluation (point t, X)."""
        self.t = t
        self._memo.clear()
        self._memo_src.clear()
        self.stats["assemblies"] += 1
        n = self.ndx
        parts = []
        for s in self.first:
            comp = s.comp
            x, u, y = self.io[comp.name]
            ew = comp.state_jacobian(t, x, u, y)
            if ew is None:
                continue
            key = ("state", comp.name)
            kept = self._kept.get(key)
            if kept is None or kept[0] is not ew or not self._same_inputs(comp, kept[2]):
                srcs = {t[0] for t in ew.terms if t[0] != "x"}
                ins = tuple((src, self.input_jacobian(comp, src)) for src in srcs)
                di, dv = [], []
                for source, rows, index, coef in ew.terms:
                    if source == "x":
                        diag = rows == index
                        di.append(s.dx.start + rows[diag]), dv.append(coef[diag])
                di = np.concatenate(di) if di else np.zeros(0, np.int64)
                dv = np.concatenate(dv) if dv else np.zeros(0)
                m = self._compose(comp, ew, skip_state=True)
                keep = self._owned[m.cols]                 # first-order on first-order: left out
                kept = (ew, (di, dv, m.rows[keep] + s.dx.start, m.cols[keep], m.vals[keep]), ins)
                self._kept[key] = kept
            parts.append(kept[1])
        # d and P are rebuilt only when some declaration changed (the same objects: the same values)
        last = self._kept.get("first-order parts")
        if last is None or len(last) != len(parts) or not all(map(operator.is_, last, parts)):
            d = np.zeros(n)
            R, C, V = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)], [np.zeros(0)]
            for di, dv, r, c, v in parts:
                np.add.at(d, di, dv)
                R.append(r), C.append(c), V.append(v)
            self.d = d
            rows, cols, vals = np.concatenate(R), np.concatenate(C), np.concatenate(V)
            order = np.argsort(rows, kind="stable")            # by row, for the factor's join
            self.P = Coo(n, rows[order], cols[order], vals[order])
            self._p_ptr = np.searchsorted(self.P.rows, np.arange(n + 1))
            self._kept["first-order parts"] = parts
        self.mech = []
        for s in self.owners:
            x, u, y = self.io[s.comp.name]
            mech = s.comp.mechanical_jacobian(self.t, x, u, y, self)
            if mech is None:                # undeclared: only q̇ = v is known (M = I, no force slopes)
                nv = s.second_order
                mech = Mechanical(M=np.eye(nv), Gq=np.zeros((nv, nv)), Gv=np.zeros((nv, nv)))
            self.mech.append((s, mech))

    def factor(self, c: float) -> None:
        """Factorise the reduced systems of I − c·J (c = γh)."""
        self.c = c
        if c != self._dinv_at[0] or self.d is not self._dinv_at[1]:    # d is replaced whenever it changes
            if self.d is not self._dinv_at[1]:
                self._dinvs.clear()
            Dinv = self._dinvs.get(c)
            if Dinv is None:
                Dinv = self._dinvs[c] = 1.0 / (1.0 - c * self.d)
            self.Dinv = Dinv
            self._dinv_at = (c, self.d)
        self.blocks = []
        P = self.P
        for s, mech in self.mech:
            nv = s.second_order
            q0 = s.dx.start
            GF = mech.GF if mech.GF is not None else _EMPTY
            if mech.structured is not None:
                extra = self._extra.get(q0)
                if extra is None or extra.size != nv:
                    extra = self._extra[q0] = np.empty(nv)     # kept: the operator may bind to it
                if kern.reduced_diagonal(extra, c, q0, nv, self.Dinv, GF.rows, GF.cols, GF.vals, self._p_ptr,
                                         P.cols, P.vals):
                    if not mech.structured.factor(c, extra):
                        raise self._singular(s, c)
                    rhs = self._rhs.get(q0)
                    if rhs is None or rhs.size != nv:
                        rhs = self._rhs[q0] = np.zeros(nv)
                    elif not GF.rows.size:
                        rhs[:] = 0.0                    # solve() writes it only when there is a share
                    self.blocks.append((True, q0, nv, mech.structured, GF, None, None, rhs))
                    continue
            M, Gq, Gv = mech.blocks()
            lu, piv = np.empty((nv, nv)), np.empty(nv, np.int64)
            kern.reduced_matrix(lu, M, Gq, Gv, c, q0, nv, self.Dinv, GF.rows, GF.cols, GF.vals,
                                self._p_ptr, P.cols, P.vals)
            if not kern.lu_factor(lu, piv):
                raise self._singular(s, c)
            self.blocks.append((False, q0, nv, (M, Gq), GF, lu, piv, np.empty(nv)))
        if not hasattr(self, "_z"):
            self._z = np.empty(self.ndx)
        parts = (c, self.Dinv, P, tuple((b[0], b[3], b[4], b[5], b[7]) for b in self.blocks))
        last = self._solve_parts
        if last is None or last[0] != c or any(a is not b for a, b in zip(last[1:3], parts[1:3])) or \
                len(last[3]) != len(parts[3]) or \
                any(a is not b for x, y in zip(last[3], parts[3]) for a, b in zip(x, y)):
            # the key names what a bound solve holds: c and the objects it reads (their ids, kept alive by
            # parts in the bound solves' caches, so an id is never reused while a cache holds it)
            self._solve_key = (c, id(self.Dinv), id(P),
                               tuple(id(a) for x in parts[3] for a in x if a is not None and not isinstance(a, bool)))
            self._solve_parts = parts

    def bind_solve(self, r: np.ndarray, out: np.ndarray):
        """:meth:`solve` (r, out) for arrays fixed for a run (an integrator's work arrays): a call without
        arguments. Owners with a structured operator that binds (``bind_solve_into``) and the
        first-order states' kernels are bound to r, out and the factorisation's arrays once per change of
        them (a new c, new declarations), so a call costs a few bound kernel calls; otherwise it is
        ``solve(r, out)``. The same arithmetic either way."""
        held = [None, ()]
        bound: dict = {}        # key -> (calls, parts): a step-size ladder switches between a few factorisations

        def solve():
            key = self._solve_key
            if held[0] != key:
                got = bound.get(key)
                if got is None:
                    if len(bound) >= 64:
                        bound.clear()
                    got = bound[key] = (self._bound_solve(r, out), self._solve_parts)
                held[0], held[1] = key, got[0]
            for call in held[1]:
                call()
        return solve

    def _bound_solve(self, r, out) -> tuple:
        c, Dinv, P, z, owned = self.c, self.Dinv, self.P, self._z, self._owned
        calls = []
        for tree, q0, nv, op, GF, lu, piv, rhs in self.blocks:
            if not tree or not hasattr(op, "bind_solve_into"):
                return (functools.partial(self.solve, r, out),)
            if GF.rows.size:
                calls.append(kern.bind(kern.first_order_rhs, r, owned, Dinv, float(c), q0, nv, GF.rows, GF.cols,
                                       GF.vals, P.rows, P.cols, P.vals, z, rhs))
            calls.append(op.bind_solve_into(r, out, q0, c, rhs))
        if self.F.size:
            calls.append(kern.bind(kern.first_order_solve, r, out, owned, Dinv, float(c), P.rows, P.cols, P.vals, z))
        return tuple(calls)

    def _singular(self, s, c) -> FloatingPointError:
        return FloatingPointError(f"{s.comp.name}: the implicit step's matrix M − γh∂Q/∂v − (γh)²∂Q/∂q is "
                                  f"singular at h = {c / self.gamma_hint:g} s" if self.gamma_hint else
                                  f"{s.comp.name}: the implicit step's matrix is singular")

    def solve(self, r: np.ndarray, out: np.ndarray) -> None:
        """out = (I − cJ)⁻¹ r (the factorised J)."""
        c, Dinv, P, z, owned = self.c, self.Dinv, self.P, self._z, self._owned
        for tree, q0, nv, op, GF, lu, piv, rhs in self.blocks:
            if tree:
                if GF.rows.size:
                    rhs[:] = 0.0
                    kern.first_order_share(r, owned, Dinv, c, q0, nv, GF.rows, GF.cols, GF.vals, P.rows, P.cols,
                                           P.vals, z, rhs)
                op.solve_into(r, out, q0, c, rhs)
            else:
                kern.owner_solve(r, out, owned, Dinv, c, q0, nv, op[0], op[1], GF.rows, GF.cols, GF.vals, P.rows,
                                 P.cols, P.vals, lu, piv, z, rhs)
        if self.F.size:
            kern.first_order_solve(r, out, owned, Dinv, c, P.rows, P.cols, P.vals, z)

    def dense(self) -> np.ndarray:
        """J as a dense (ndx × ndx) matrix, as the solve uses it (tests compare it with finite
        differences)."""
        n = self.ndx
        J = np.zeros((n, n))
        J[np.arange(n), np.arange(n)] = np.where(self._owned, 0.0, self.d)
        np.add.at(J, (self.P.rows, self.P.cols), self.P.vals)
        for s, mech in self.mech:
            nv = s.second_order
            q0 = s.dx.start
            qs, vs = slice(q0, q0 + nv), slice(q0 + nv, q0 + 2 * nv)
            J[qs, vs] += np.eye(nv)
            M, Gq, Gv = mech.blocks()
            Minv = np.linalg.inv(M)
            J[vs, qs] += Minv @ Gq
            J[vs, vs] += Minv @ Gv
            if mech.GF is not None:
                G = np.zeros((nv, n))
                np.add.at(G, (mech.GF.rows, mech.GF.cols), mech.GF.vals)
                J[vs, :] += np.where(self._owned[None, :], 0.0, Minv @ G)
        return J


def _base(name):
    from .component import Component
    return getattr(Component, name)
