"""The multibody's Jacobian block for linearly implicit integrators (framework/linearization.py).

    M(q) v̇ = Q(q, v, τ, W) − C(q, v),      Q = τ − damping·v + Σ_l J_lᵀ W_l

The block is M (Pinocchio's CRBA, armature included), ∂Q/∂q and ∂Q/∂v from

- the joint torque input τ, through whatever its source declares (a PID's gains: an
  ``Elementwise`` on joint_q / joint_v, which this multibody declares as ``Selection``s of its
  state), so the PID's integral and filter states enter as ∂Q/∂(other states);
- joint damping (−damping on the DOF diagonal);
- the link wrench input W, when its source declares a :class:`LinkWrenchJacobian` (or sums such
  sources, declaring an ``Elementwise`` of unit coefficients): per link l the
  6×6 derivatives of W_l (world axes, about the link origin) with respect to the link's twist
  V_l = [v of its origin, ω] and to its small displacement [δp of its origin, δθ]. They enter
  as Σ_l J_lᵀ A_l J_l, with J_l the link's (6 × nv) Jacobian, which :func:`tree_quadratic`
  forms on the link tree without forming J_l: the composite-rigid-body recursion with the
  inertias replaced by the (not necessarily symmetric) A_l, O(nl · depth).

Left out (a W-method tolerates it; all are smooth and slow): the Coriolis and gravity terms'
derivatives, and the change of the lever arms and contact normals with the link's rotation.

The block goes to the integrator as a structured operator (:class:`ArticulatedW`), never as
dense matrices: M from the links' spatial inertias and the armature, the contact blocks kept per
link, the torque slopes as joint diagonals, and M − c G_v − c² G_q + diag(e) eliminated on the
link tree in O(links) (articulated_solve_kernels.py; at 100 EELS 1.0 modules the assembly,
factorisation and solve take ~0.3, 0.06 and 0.05 ms where CRBA + the composite sums and the
dense LU took 1.8, 4.7 and 0.19 ms). The dense path (CRBA or the tree's M, :func:`tree_quadratic`,
one LU) remains for a torque slope off the joint diagonal and for a model whose mimic joints do
not hang from one body (screw_pairs: mimic_crba: no block at all, see the component).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from snakesim.framework.linearization import Coo, Elementwise, Mechanical

from ..kernel_args import bind
from . import articulated_solve_kernels as ask
from .kernels import REVOLUTE, ROOT, _same_bits


@dataclass(frozen=True)
class LinkWrenchJacobian:
    """Derivatives of a (nl, 6) link-wrench output ([f, τ about each link origin], world axes).

    rows      links that carry a non-zero block
    d_twist   (nl, 6, 6) ∂W_l/∂V_l, V_l = [v of the link origin, ω] (world axes), N·s/m ...
    d_pose    (nl, 6, 6) ∂W_l/∂δ_l, δ_l = [δp of the link origin, δθ] (world axes), N/m ...
    inputs    the input ports carrying the links' poses and twists (checked by the reader: they must
              come from the multibody the wrenches go to)
    """

    rows: np.ndarray
    d_twist: np.ndarray
    d_pose: np.ndarray
    inputs: tuple[str, ...]


@njit(cache=True)
def _shift_block(rx, ry, rz, A, out):
    """out += Tᵀ A T, T = [[I, L], [0, I]], L = −[r]×: a 6×6 block about a link origin moved to a point
    at −r from it (twists and wrenches in world axes). No allocation."""
    L = np.empty((3, 3))
    L[0, 0], L[0, 1], L[0, 2] = 0.0, rz, -ry
    L[1, 0], L[1, 1], L[1, 2] = -rz, 0.0, rx
    L[2, 0], L[2, 1], L[2, 2] = ry, -rx, 0.0
    # X = A T: left columns A[:, :3], right columns A[:, :3] L + A[:, 3:]
    X = np.empty((6, 6))
    for i in range(6):
        for j in range(3):
            X[i, j] = A[i, j]
            X[i, 3 + j] = A[i, 0] * L[0, j] + A[i, 1] * L[1, j] + A[i, 2] * L[2, j] + A[i, 3 + j]
    # Tᵀ X: top rows X[:3], bottom rows Lᵀ X[:3] + X[3:]
    for j in range(6):
        for i in range(3):
            out[i, j] += X[i, j]
            out[3 + i, j] += L[0, i] * X[0, j] + L[1, i] * X[1, j] + L[2, i] * X[2, j] + X[3 + i, j]


@njit(cache=True)
def tree_quadratic(order, parent, jtype, vidx, mult, R, p, aw, rows, A, C, H):
    """H += Σ_l J_lᵀ A_l J_l for the links in ``rows`` (A_l about link l's origin, world axes).

    J_l maps v to link l's twist. Every block is moved to the root origin O (T_l = [[I, −[o_l −
    O]×], [0, I]]: A ← T_lᵀ A T_l), summed over subtrees into C (nl, 6, 6 scratch), and
    H[k, i] += m_k m_i s_kᵀ C_i s_i for every revolute ancestor-or-self k of a revolute link i,
    s_i = [a_i × (O − p_i), a_i] the joint's unit twist at O; the free-flyer's columns are
    blockdiag(R_root, R_root) (Pinocchio's local velocity).
    """
    root = order[0]
    C[:, :, :] = 0.0
    for k in range(rows.size):
        l = rows[k]
        _shift_block(p[l, 0] - p[root, 0], p[l, 1] - p[root, 1], p[l, 2] - p[root, 2], A[l], C[l])
    nz = np.zeros(C.shape[0], dtype=np.bool_)
    for k in range(rows.size):
        nz[rows[k]] = True
    for k in range(order.size - 1, 0, -1):
        l = order[k]
        if nz[l]:
            P = parent[l]
            C[P] += C[l]
            nz[P] = True
    s = np.empty((C.shape[0], 6))
    for l in range(C.shape[0]):
        if jtype[l] == REVOLUTE:
            cx = aw[l, 1] * (p[root, 2] - p[l, 2]) - aw[l, 2] * (p[root, 1] - p[l, 1])
            cy = aw[l, 2] * (p[root, 0] - p[l, 0]) - aw[l, 0] * (p[root, 2] - p[l, 2])
            cz = aw[l, 0] * (p[root, 1] - p[l, 1]) - aw[l, 1] * (p[root, 0] - p[l, 0])
            s[l, 0], s[l, 1], s[l, 2] = cx, cy, cz
            s[l, 3], s[l, 4], s[l, 5] = aw[l, 0], aw[l, 1], aw[l, 2]
    Sb = np.zeros((6, 6))
    for i in range(3):
        for j in range(3):
            Sb[i, j] = R[root, i, j]
            Sb[3 + i, 3 + j] = R[root, i, j]
    H[0:6, 0:6] += Sb.T @ C[root] @ Sb
    F = np.empty(6)
    G = np.empty(6)
    for l in range(C.shape[0]):
        if jtype[l] != REVOLUTE or not nz[l]:
            continue
        Cl = C[l]
        for i in range(6):
            F[i] = 0.0
            G[i] = 0.0
            for j in range(6):
                F[i] += Cl[i, j] * s[l, j]
                G[i] += Cl[j, i] * s[l, j]
        vi, mi = vidx[l], mult[l]
        # the free-flyer's rows and columns
        for c in range(6):
            a, b = 0.0, 0.0
            for i in range(6):
                a += Sb[i, c] * F[i]
                b += Sb[i, c] * G[i]
            H[c, vi] += mi * a
            H[vi, c] += mi * b
        # itself and its revolute ancestors
        H[vi, vi] += mi * mi * (s[l, 0] * F[0] + s[l, 1] * F[1] + s[l, 2] * F[2] + s[l, 3] * F[3] + s[l, 4] * F[4]
                                + s[l, 5] * F[5])
        k = parent[l]
        while k >= 0 and jtype[k] != ROOT:
            if jtype[k] == REVOLUTE:
                vk, mk = vidx[k], mult[k]
                a, b = 0.0, 0.0
                for i in range(6):
                    a += s[k, i] * F[i]
                    b += s[k, i] * G[i]
                H[vk, vi] += mk * mi * a
                H[vi, vk] += mi * mk * b
            k = parent[k]


@njit(cache=True)
def symmetric_from_upper(src, out):
    """out = src with its strict lower triangle mirrored from the upper one (Pinocchio's CRBA fills
    the upper)."""
    n = src.shape[0]
    for i in range(n):
        for j in range(i, n):
            out[i, j] = src[i, j]
            out[j, i] = src[i, j]


class ArticulatedW:
    """The structured operator of a multibody's :class:`Mechanical` block
    (framework/linearization.py): M − c G_v − c² G_q + diag(e) factorised and solved on the link
    tree in O(links) (articulated_solve_kernels.py), M from the links' inertias and the armature,
    G_q and G_v from the contact's link blocks and the joint-diagonal torque slopes. One per run
    (the multibody's cache); every array is preallocated."""

    def __init__(self, mb, plan):
        ta = mb._ta
        nl, nv = ta.order.size, mb._nv
        self.ta, self.nv, self.arm = ta, nv, mb._arm_v
        self.anc_ptr, self.anc_dof = plan
        z6 = lambda: np.zeros((nl, 6, 6))  # noqa: E731
        self.atw, self.apo, self.Iin, self.AtwO, self.ApO, self.Ia = z6(), z6(), z6(), z6(), z6(), z6()
        self.has_a = np.zeros(nl, dtype=np.bool_)
        self.sig = np.zeros((nl, 6))
        self.Ucol, self.Urow, self.D = np.zeros((nv, 6)), np.zeros((nv, 6)), np.zeros(nv)
        self.root_lu, self.root_piv = np.zeros((6, 6)), np.zeros(6, np.int64)
        self.d = np.zeros(nv)
        self.pb, self.V, self.V2, self.F = np.zeros((nl, 6)), np.zeros((nl, 6)), np.zeros((nl, 6)), np.zeros((nl, 6))
        self.b = np.zeros(nv)
        self.done = np.zeros(nv, dtype=np.bool_)
        # refreshed in place by prepare(), so a bound solve (bind_solve_into) keeps reading them
        self.gq, self.gv = np.zeros(nv), np.zeros(nv)
        self.R = np.zeros((nl, 3, 3))

    def prepare(self, frames, terms, gq, gv, solved=None) -> None:
        """The state-dependent parts at the current kinematics: ``frames`` (R, p, aw of every link),
        ``terms`` the LinkWrenchJacobians reaching the wrench input, gq, gv the joint-diagonal
        ∂τ/∂q, ∂τ/∂v (nv; joint damping included in gv). ``solved``: (Iin, sig, at_q, q), the forward
        dynamics' link inertias and joint twists and the configuration they were computed at: copied
        instead of recomputed when at_q is q, bit for bit."""
        R, p, aw = frames
        ta = self.ta
        self.has_a[:] = False
        atw, apo = self.atw, self.apo
        if len(terms) == 1 and terms[0].d_twist.shape == atw.shape:
            atw, apo = terms[0].d_twist, terms[0].d_pose        # read in place: prepare() copies the rows
            self.has_a[terms[0].rows] = True
        elif terms:
            atw[:] = 0.0
            apo[:] = 0.0
            for wj in terms:
                atw[wj.rows] += wj.d_twist[wj.rows]
                apo[wj.rows] += wj.d_pose[wj.rows]
                self.has_a[wj.rows] = True
        np.copyto(self.R, R)        # the cache's frames move with every stage's evaluation; the factor stays
        np.copyto(self.gq, gq)
        np.copyto(self.gv, gv)
        if solved is not None and _same_bits(solved[2], solved[3]):
            ask.prepare_from(ta.order, p, self.has_a, atw, apo, solved[0], solved[1], self.Iin, self.AtwO, self.ApO,
                             self.sig)
        else:
            ask.prepare(ta.order, ta.jtype, ta.mult, ta.mass, ta.com, ta.inertia, R, p, aw, self.has_a, atw, apo,
                        self.Iin, self.AtwO, self.ApO, self.sig)

    def factor(self, c: float, extra: np.ndarray) -> bool:
        """Factorise M − c G_v − c² G_q + diag(extra); False if a pivot is zero. Bound (one record) to this
        c and extra array while they stay the same (a fixed step: the whole run)."""
        bound = getattr(self, "_factor_bound", None)
        if bound is None or bound[0] != c or bound[1] is not extra:
            ta = self.ta
            rec = ask.WFactor(order=ta.order, parent=ta.parent, jtype=ta.jtype, vidx=ta.vidx, anc_ptr=self.anc_ptr,
                              anc_dof=self.anc_dof, R=self.R, Iin=self.Iin, AtwO=self.AtwO, ApO=self.ApO,
                              has_a=self.has_a, sig=self.sig, c=float(c), arm=self.arm, gv=self.gv, gq=self.gq,
                              extra=extra, d=self.d, Ia=self.Ia, Ucol=self.Ucol, Urow=self.Urow, D=self.D,
                              root_lu=self.root_lu, root_piv=self.root_piv)
            bound = self._factor_bound = (c, extra, bind(ask.factor_step, rec))
        return bound[2]()

    def solve_into(self, r, out, q0, c, extra) -> None:
        """The owner's rows of (I − cJ)⁻¹ r into out (framework/linearization.py): rhs M r_v + c G_q r_q
        + extra, solved, k_q = r_q + c k_v; r_q = r[q0:q0 + nv], r_v after it."""
        ta = self.ta
        ask.rhs_solve(ta.order, ta.parent, ta.jtype, ta.vidx, self.anc_ptr, self.anc_dof, self.R, self.sig, self.Iin,
                      self.ApO, self.has_a, self.arm, self.gq, self.Ucol, self.Urow, self.D, self.root_lu,
                      self.root_piv, c, r, q0, extra, self.b, self.pb, self.V, self.V2, self.F, self.done, out)

    def bind_solve_into(self, r, out, q0, c, extra):
        """:meth:`solve_into` for arrays fixed for a run (an integrator's work arrays) and this ``c``: a
        call without arguments (one record, no per-call argument typing: ~1 µs instead of ~6)."""
        ta = self.ta
        rec = ask.WSolve(order=ta.order, parent=ta.parent, jtype=ta.jtype, vidx=ta.vidx, anc_ptr=self.anc_ptr,
                         anc_dof=self.anc_dof, R=self.R, sig=self.sig, Iin=self.Iin, ApO=self.ApO, has_a=self.has_a,
                         arm=self.arm, gq=self.gq, Ucol=self.Ucol, Urow=self.Urow, D=self.D, root_lu=self.root_lu,
                         root_piv=self.root_piv, c=float(c), r=r, q0=int(q0), extra=extra, b=self.b, pb=self.pb,
                         V=self.V, V2=self.V2, F=self.F, done=self.done, out=out)
        return bind(ask.rhs_solve_step, rec)

    def solve(self, b) -> None:
        """b ← (the factorised matrix)⁻¹ b."""
        ta = self.ta
        ask.solve(ta.order, ta.parent, ta.jtype, ta.vidx, self.anc_ptr, self.anc_dof, self.R, self.sig, self.Ucol,
                  self.Urow, self.D, self.root_lu, self.root_piv, b, self.pb, self.V, self.done)

    def dense(self):
        """(M, Gq, Gv) as dense matrices, column by column on the tree (O(nv · links): tests and the
        fallback when the first-order share is not diagonal)."""
        ta, nv = self.ta, self.nv
        M, Gq, Gv = np.zeros((nv, nv)), np.zeros((nv, nv)), np.zeros((nv, nv))
        no = np.zeros_like(self.has_a)
        e, zero, col = np.zeros(nv), np.zeros(nv), np.empty(nv)
        for j in range(nv):
            e[j] = 1.0
            for out, blocks, diag in ((M, self.Iin, self.arm), (Gq, self.ApO, self.gq), (Gv, self.AtwO, self.gv)):
                ask.apply(ta.order, ta.parent, ta.jtype, ta.vidx, self.R, self.sig, blocks, blocks, no, 0.0, zero, e,
                          diag, zero, col, self.V, self.V2, self.pb)
                out[:, j] = col
            e[j] = 0.0
        return M, Gq, Gv


def _torque_terms(mb, lin, tau):
    """(tau, gq, gv, GF, dense): the torque input's slopes as joint diagonals gq, gv (nv; joint damping
    in gv), its dependence on other states GF, and (Gq0, Gv0) dense when some entry is off the
    diagonal (else None)."""
    nv = mb._nv
    dof = mb._dof_v
    gq, gv = np.zeros(nv), np.zeros(nv)
    gv[dof] -= mb._damp
    GF, dense = None, None
    if tau is not None and tau.rows.size:
        q0 = lin.slices[mb.name].dx.start
        r, cols, vals = dof[tau.rows], tau.cols, tau.vals
        inq = (cols >= q0) & (cols < q0 + nv)
        inv = (cols >= q0 + nv) & (cols < q0 + 2 * nv)
        if np.all(cols[inq] - q0 == r[inq]) and np.all(cols[inv] - q0 - nv == r[inv]):
            np.add.at(gq, r[inq], vals[inq])
            np.add.at(gv, r[inv], vals[inv])
        else:
            Gq0, Gv0 = np.zeros((nv, nv)), np.diag(gv)
            np.add.at(Gq0, (r[inq], cols[inq] - q0), vals[inq])
            np.add.at(Gv0, (r[inv], cols[inv] - q0 - nv), vals[inv])
            dense = (Gq0, Gv0)
        other = ~(inq | inv | lin._owned[cols])              # another multibody's state: left out
        if other.any():
            GF = Coo(nv, r[other], cols[other], vals[other])
    return tau, gq, gv, GF, dense


def mechanical_block(mb, t, x, u, y, lin):
    """The multibody's :class:`~snakesim.framework.linearization.Mechanical` block at (q, v): the
    structured (link-tree) operator, or dense M (CRBA), Gq, Gv where the tree recursion does not
    apply (a DOF moving links on different bodies, a torque slope off the joint diagonal)."""
    c = u.cache
    tau = lin.input_jacobian(mb, "tau")
    if c.lin_tau is None or c.lin_tau[0] is not tau:
        c.lin_tau = _torque_terms(mb, lin, tau)
    _, gq, gv, GF, dense = c.lin_tau
    if mb._stops is not None:                           # pushing joint stops: −k, −c on the diagonal (joint_stops.py)
        gq, gv, dense = mb._stops.slopes(c.q, c.v, c.a, lin.plan.dt, gq, gv, dense)
    terms = _link_wrench_terms(lin, mb, mb, "wrenches")
    c.ensure_kinematics()
    if dense is None and mb._tree_plan is not None and mb.structured_solve:
        if c.lin_op is None:
            c.lin_op = ArticulatedW(mb, mb._tree_plan)
        c.lin_op.prepare(c.frames, terms, gq, gv, c.solved)
        return Mechanical(M=None, Gq=None, Gv=None, GF=GF, structured=c.lin_op)
    if mb.dyn.tree_mass_matrix is None:                 # Pinocchio's CRBA (it fills the upper triangle)
        M = np.empty((mb._nv, mb._nv))
        symmetric_from_upper(mb._pin.crba(mb.dyn.model, mb.dyn.data, c.q), M)
    else:
        M = mb.dyn.mass_matrix(c.q)
    Gq, Gv = (dense[0].copy(), dense[1].copy()) if dense is not None else (np.diag(gq), np.diag(gv))
    R, p, aw = c.frames
    ta = mb._ta
    for wj in terms:
        C = c.lin_scratch
        tree_quadratic(ta.order, ta.parent, ta.jtype, ta.vidx, ta.mult, R, p, aw, wj.rows, wj.d_twist, C, Gv)
        tree_quadratic(ta.order, ta.parent, ta.jtype, ta.vidx, ta.mult, R, p, aw, wj.rows, wj.d_pose, C, Gq)
    return Mechanical(M=M, Gq=Gq, Gv=Gv, GF=GF)


def _link_wrench_terms(lin, mb, comp, port, depth=0):
    """The LinkWrenchJacobians that reach ``comp.port``: declared by its source, or by the sources of
    a sum (an ``Elementwise`` whose terms are inputs added element for element with coefficient 1:
    a wrench summing junction). Each must be driven by ``mb``'s own link poses and twists."""
    wj, up = lin.source_jacobian(comp, port)
    if isinstance(wj, LinkWrenchJacobian):
        return [wj] if wj.rows.size and _driven_by(lin, up, wj.inputs, mb) else []
    out = []
    if isinstance(wj, Elementwise) and depth < 8:
        key = ("wrench-sum", up.name)                 # the sum's structure: checked once per declaration
        kept = lin._kept.get(key)
        if kept is None or kept[0] is not wj:
            kept = (wj, [source for source, rows, index, coef in wj.terms
                         if source != "x" and np.array_equal(rows, index) and rows.size == wj.size
                         and np.all(coef == 1.0)])
            lin._kept[key] = kept
        for source in kept[1]:
            out += _link_wrench_terms(lin, mb, up, source, depth + 1)
    return out


def _driven_by(lin, comp, inputs, mb) -> bool:
    """True if every one of ``comp``'s ``inputs`` comes straight from ``mb`` (the wiring: asked once)."""
    key = ("driven", comp.name, inputs, mb.name)
    if key not in lin._kept:
        srcs = [lin.source(comp, port) for port in inputs]
        lin._kept[key] = all(src is not None and src[0] is mb for src in srcs)
    return lin._kept[key]
