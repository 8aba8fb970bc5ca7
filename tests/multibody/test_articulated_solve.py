"""The O(links) factorisation of the implicit step's matrix (articulated_solve_kernels.py).

W = Σ_l J_lᵀ (I_l − c A_l^twist − c² A_l^pose) J_l + diag(d) is built here independently, from
explicit link Jacobians J_l (6 × nv, column by column from the joint axes and the free-flyer's
blockdiag(R_root, R_root)), and its dense solve is the reference:

* random trees (branches, fixed links, counter-rotating mimic pairs sharing one DOF, non-symmetric
  link blocks): the tree solve agrees to 1e-10 relative, ``apply`` gives M r_v + c G_q r_q;
* the EELS 1.0 models at 10 and 100 modules in the default scene, contact on: the tree's M equals
  Pinocchio's CRBA (10), its G_q and G_v the dense composite-rigid-body sums (tree_quadratic),
  and the integrator's structured solve agrees with the dense LU path to the round-off the
  matrix's condition allows;
* a rosenbrock_w run is the same with either solve;
* the forward dynamics on the link tree (no Pinocchio Data) equals Pinocchio's ABA.
"""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.multibody import articulated_solve_kernels as ask
from snakesim.components.multibody.kernels import FIXED, REVOLUTE, ROOT


def _rot(rng):
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    return q * np.sign(np.linalg.det(q))


def random_tree(rng, n_dof_links=12, n_pairs=3, n_fixed=4):
    """Link-tree arrays: a root, revolute links with their own DOF, mimic pairs (two links, one DOF,
    multipliers 1 and −1, hanging from one body through a fixed link for one of them), fixed links."""
    parent, jtype, vidx, mult = [-1], [ROOT], [0], [1.0]
    nv = 6

    def add(p, jt, k=0, m=1.0):
        parent.append(p), jtype.append(jt), vidx.append(k), mult.append(m)
        return len(parent) - 1

    bodies = [0]
    for _ in range(n_dof_links):
        bodies.append(add(int(rng.choice(bodies)), REVOLUTE, nv))
        nv += 1
    for _ in range(n_fixed):
        bodies.append(add(int(rng.choice(bodies)), FIXED))
    for _ in range(n_pairs):
        body = int(rng.choice(bodies))
        mount = add(body, FIXED)                     # the rear screw hangs from a frame on the body
        add(body, REVOLUTE, nv, 1.0)
        add(mount, REVOLUTE, nv, -1.0)
        nv += 1
    n = len(parent)
    parent = np.array(parent, np.int64)
    depth = np.zeros(n, np.int64)
    for l in range(1, n):
        depth[l] = depth[parent[l]] + 1
    order = np.argsort(depth, kind="stable").astype(np.int64)      # parents before children
    R = np.array([_rot(rng) for _ in range(n)])
    p = rng.uniform(-1.5, 1.5, (n, 3))
    aw = rng.standard_normal((n, 3))
    aw /= np.linalg.norm(aw, axis=1)[:, None]
    mass = rng.uniform(0.5, 3.0, n)
    com = rng.uniform(-0.1, 0.1, (n, 3))
    inertia = np.empty((n, 3, 3))
    for l in range(n):
        Q = _rot(rng)
        inertia[l] = Q @ np.diag(rng.uniform(0.01, 0.1, 3)) @ Q.T
    return dict(order=order, parent=parent, jtype=np.array(jtype, np.int64), vidx=np.array(vidx, np.int64),
                mult=np.array(mult), R=R, p=p, aw=aw, mass=mass, com=com, inertia=inertia, nv=nv)


def link_jacobians(t):
    """J_l (nl, 6, nv): twist [v of the root origin O, ω] (world axes) of each link's frame moving
    with it, from the joint axes: the free-flyer's columns blockdiag(R_root, R_root), a revolute
    ancestor-or-self k adds m_k [a_k × (O − p_k), a_k] in its DOF's column."""
    order, parent, jtype, vidx, mult = t["order"], t["parent"], t["jtype"], t["vidx"], t["mult"]
    root = order[0]
    O = t["p"][root]
    n, nv = order.size, t["nv"]
    J = np.zeros((n, 6, nv))
    for l in range(n):
        J[l, :3, :3] = t["R"][root]
        J[l, 3:, 3:6] = t["R"][root]
        k = l
        while k != root:
            if jtype[k] == REVOLUTE:
                a = t["aw"][k]
                J[l, :3, vidx[k]] += mult[k] * np.cross(a, O - t["p"][k])
                J[l, 3:, vidx[k]] += mult[k] * a
            k = parent[k]
    return J


def spatial_inertia_at(t, l, O):
    """Link l's spatial inertia about O, world axes ([linear, angular])."""
    R = t["R"][l]
    r = R @ t["com"][l] + t["p"][l] - O
    m = t["mass"][l]
    X = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    return np.block([[m * np.eye(3), -m * X], [m * X, R @ t["inertia"][l] @ R.T - m * X @ X]])


def shift_to(A, r):
    """A block about a link origin, moved to O at −r from it: Tᵀ A T, T = [[I, −[r]×], [0, I]]."""
    X = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    T = np.block([[np.eye(3), -X], [np.zeros((3, 3)), np.eye(3)]])
    return T.T @ A @ T


class TreeOp:
    """The kernels driven as the multibody's ArticulatedW drives them."""

    def __init__(self, t, atw, apo, has_a):
        self.t = t
        n, nv = t["order"].size, t["nv"]
        (self.ptr, self.dof), why = ask.tree_plan(t["order"], t["parent"], t["jtype"], t["vidx"], nv)
        assert why is None
        z = lambda: np.zeros((n, 6, 6))  # noqa: E731
        self.Iin, self.AtwO, self.ApO, self.Ia = z(), z(), z(), z()
        self.sig = np.zeros((n, 6))
        self.has_a = has_a
        ask.prepare(t["order"], t["jtype"], t["mult"], t["mass"], t["com"], t["inertia"], t["R"], t["p"], t["aw"],
                    has_a, atw, apo, self.Iin, self.AtwO, self.ApO, self.sig)
        self.Ucol, self.Urow, self.D = np.zeros((nv, 6)), np.zeros((nv, 6)), np.zeros(nv)
        self.lu, self.piv = np.zeros((6, 6)), np.zeros(6, np.int64)
        self.s1, self.s2, self.s3 = np.zeros((n, 6)), np.zeros((n, 6)), np.zeros((n, 6))

    def factor(self, c, d):
        t = self.t
        return ask.factor(t["order"], t["parent"], t["jtype"], t["vidx"], self.ptr, self.dof, t["R"], self.Iin,
                          self.AtwO, self.ApO, self.has_a, self.sig, c, d, self.Ia, self.Ucol, self.Urow, self.D,
                          self.lu, self.piv)

    def solve(self, b):
        t = self.t
        x = b.copy()
        ask.solve(t["order"], t["parent"], t["jtype"], t["vidx"], self.ptr, self.dof, t["R"], self.sig, self.Ucol,
                  self.Urow, self.D, self.lu, self.piv, x, self.s1, self.s2, np.zeros(t["nv"], np.bool_))
        return x

    def apply(self, c, rq, rv, dv, dq):
        t = self.t
        out = np.zeros(t["nv"])
        ask.apply(t["order"], t["parent"], t["jtype"], t["vidx"], t["R"], self.sig, self.Iin, self.ApO, self.has_a,
                  c, rq, rv, dv, dq, out, self.s1, self.s2, self.s3)
        return out


@pytest.mark.parametrize("seed", range(6))
def test_tree_solve_matches_the_dense_solve_on_random_trees(seed):
    rng = np.random.default_rng(seed)
    t = random_tree(rng)
    n, nv = t["order"].size, t["nv"]
    O = t["p"][t["order"][0]]
    has_a = rng.random(n) < 0.6
    atw = rng.standard_normal((n, 6, 6)) * 50.0       # not symmetric: friction blocks are not
    apo = rng.standard_normal((n, 6, 6)) * 2e3
    atw -= 200.0 * np.eye(6)                         # damping-like: −c A_twist adds to the diagonal
    J = link_jacobians(t)
    c = 0.01
    d = np.zeros(nv)
    d[6:] = rng.uniform(0.0, 0.3, nv - 6)
    M = sum(J[l].T @ spatial_inertia_at(t, l, O) @ J[l] for l in range(n))
    Atw = sum(J[l].T @ shift_to(atw[l], t["p"][l] - O) @ J[l] for l in range(n) if has_a[l])
    Apo = sum(J[l].T @ shift_to(apo[l], t["p"][l] - O) @ J[l] for l in range(n) if has_a[l])
    W = M - c * Atw - c * c * Apo + np.diag(d)
    op = TreeOp(t, atw, apo, has_a)
    assert op.factor(c, d)
    for _ in range(3):
        b = rng.standard_normal(nv)
        x_ref = np.linalg.solve(W, b)
        assert np.abs(op.solve(b) - x_ref).max() <= 1e-10 * np.abs(x_ref).max()
    # the right-hand side's operator: M r_v + c G_q r_q with the joint diagonals dv, dq
    rq, rv = rng.standard_normal(nv), rng.standard_normal(nv)
    dv, dq = rng.uniform(0, 1, nv), rng.uniform(-5, 5, nv)
    ref = (M + np.diag(np.r_[np.zeros(6), dv[6:]])) @ rv + c * (Apo + np.diag(np.r_[np.zeros(6), dq[6:]])) @ rq
    assert np.abs(op.apply(c, rq, rv, dv, dq) - ref).max() <= 1e-12 * np.abs(ref).max()


def test_tree_plan_refuses_a_dof_on_two_bodies():
    """A DOF whose links hang from different bodies is not a tree elimination: the plan says so (the
    multibody then keeps the dense LU)."""
    order = np.arange(4, dtype=np.int64)
    parent = np.array([-1, 0, 1, 0], np.int64)
    jtype = np.array([ROOT, REVOLUTE, REVOLUTE, REVOLUTE], np.int64)
    vidx = np.array([0, 6, 7, 7], np.int64)
    plan, why = ask.tree_plan(order, parent, jtype, vidx, 8)
    assert plan is None and "different bodies" in why
    plan, why = ask.tree_plan(order, parent, jtype, np.array([0, 6, 7, 8]), 9)
    assert why is None and plan[0][-1] == 3


def _scene(modules):
    from snakesim.framework.session import load_session
    s = load_session("surface-screw-traverse", overrides=[f"robot.modules={modules}", "settle=0.1"],
                     sim_overrides={"duration": 0.15, "integrator": "rosenbrock_w", "dt": 5e-3})
    s.run()
    return s


@pytest.mark.parametrize("modules", [10, 100])
def test_eels_tree_blocks_and_solve_match_the_dense_path(modules):
    from snakesim.framework.linearization import Linearization
    s = _scene(modules)
    p, t = s.plan, 0.15
    p.f(t, p.X)
    mb = p.components["robot"]
    lins = {}
    tree_m = mb.dyn.tree_mass_matrix
    if modules <= 30:
        mb.dyn.tree_mass_matrix = None          # the dense path's M from Pinocchio's CRBA (a Data: small here)
    for structured in (True, False):
        mb.structured_solve = structured
        lins[structured] = lin = Linearization(p)
        lin.assemble(t)
        assert (lin.mech[0][1].structured is not None) == structured
    mb.structured_solve = True
    mb.dyn.tree_mass_matrix = tree_m
    op = lins[True].mech[0][1].structured
    assert op.has_a.sum() >= modules                 # the screws are in contact: the blocks are there
    # the link inertias and joint twists were the forward dynamics' (same configuration): as computed afresh
    ta, nl = mb._ta, mb._ta.order.size
    R, pos, aw = p.caches["robot"].frames
    z = np.zeros((nl, 6, 6))
    Iin, sig = np.zeros((nl, 6, 6)), np.zeros((nl, 6))
    ask.prepare(ta.order, ta.jtype, ta.mult, ta.mass, ta.com, ta.inertia, R, pos, aw, np.zeros(nl, np.bool_), z, z,
                Iin, z.copy(), z.copy(), sig)
    np.testing.assert_array_equal(op.Iin, Iin)
    np.testing.assert_array_equal(op.sig, sig)
    M1, Gq1, Gv1 = lins[True].mech[0][1].blocks()
    M0, Gq0, Gv0 = lins[False].mech[0][1].blocks()     # CRBA and the composite-rigid-body sums
    for a, b in ((M1, M0), (Gq1, Gq0), (Gv1, Gv0)):
        assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()
    rng = np.random.default_rng(1)
    nv = M0.shape[0]
    for c in (1.7 * 5e-3, 1.7 * 1e-2):
        # the multibody's reduced matrix alone (no first-order share): residual at round-off
        W = M0 - c * Gv0 - c * c * Gq0
        assert op.factor(c, np.zeros(nv))
        b = rng.standard_normal(nv)
        x = b.copy()
        op.solve(x)
        x_ref = np.linalg.solve(W, b)
        cond = np.linalg.cond(W)
        assert np.abs(W @ x - b).max() <= 1e-12 * np.abs(W).max() * np.abs(x).max()
        assert np.abs(x - x_ref).max() <= max(1e-10, 1e-15 * cond) * np.abs(x_ref).max()
        # the whole (I − cJ)⁻¹ r, PID states included
        for lin in lins.values():
            lin.factor(c)
        r = rng.standard_normal(p.ndx)
        o1, o0 = np.zeros(p.ndx), np.zeros(p.ndx)
        lins[True].solve(r, o1)
        lins[False].solve(r, o0)
        assert np.abs(o1 - o0).max() <= max(1e-10, 1e-15 * cond) * np.abs(o0).max()
        ob = np.zeros(p.ndx)                # bound to the arrays (the integrator's way): the same arithmetic
        lins[True].bind_solve(r, ob)()
        np.testing.assert_array_equal(ob, o1)


def test_rosenbrock_run_is_the_same_with_the_tree_solve():
    """10 modules, 0.3 s of the default scene at 5 ms: the final state with the tree solve and with the
    dense LU agree to round-off amplified by the run (1e-9 relative)."""
    from snakesim.framework.session import load_session
    out = {}
    for structured in (True, False):
        s = load_session("surface-screw-traverse", overrides=["robot.modules=10", "settle=0.1"],
                         sim_overrides={"duration": 0.3, "integrator": "rosenbrock_w", "dt": 5e-3})
        s.plan.components["robot"].structured_solve = structured
        r = s.run()
        assert r.summary["completed"]
        out[structured] = s.plan.X.copy()
    assert np.abs(out[True] - out[False]).max() <= 1e-9 * max(1.0, np.abs(out[False]).max())


def _session(modules, dynamics, integrator="rosenbrock_w"):
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry
    from snakesim.framework.session import Session
    reg = default_registry()
    resolved = resolve("surface-screw-traverse", search_path=reg.assembly_paths(),
                       overrides=[f"robot.modules={modules}", "settle=0.1"],
                       sim_overrides={"duration": 0.15, "integrator": integrator, "dt": 5e-3})
    resolved.components["robot"].params["dynamics"] = dynamics
    return Session(resolved, reg)


@pytest.mark.parametrize("modules", [2, 10])
def test_tree_forward_dynamics_matches_pinocchio_aba(modules):
    """The link-tree forward dynamics (no Pinocchio Data) against Pinocchio's ABA on the same state
    and inputs: driving on the ground with contact, then with random joint and base rates added
    (Coriolis and gyroscopic terms), to 1e-10 of the largest acceleration term's scale."""
    from snakesim.components.multibody import model as mb_model
    tree, ref = _session(modules, "tree"), _session(modules, "pinocchio")
    assert tree.plan.components["robot"].forward_dynamics == "tree"
    made = mb_model.DATA_MADE[0]
    tree.run()
    assert mb_model.DATA_MADE[0] == made                 # the tree needs no Data
    X = tree.plan.X.copy()
    nv = tree.plan.components["robot"]._nv
    robot = next(sl for sl in tree.plan.slices if sl.second_order)
    rng = np.random.default_rng(modules)
    for extra in (0.0, 1.0):
        X1 = X.copy()
        X1[robot.x.stop - nv:robot.x.stop] += extra * rng.uniform(-2.0, 2.0, nv)
        np.copyto(tree.plan.X, X1)
        np.copyto(ref.plan.X, X1)
        f_tree = tree.plan.f(0.15, tree.plan.X).copy()
        f_ref = ref.plan.f(0.15, ref.plan.X).copy()
        vs = slice(robot.dx.start + nv, robot.dx.start + 2 * nv)
        scale = max(np.abs(f_ref[vs]).max(), 9.81)
        assert np.abs(f_tree[vs] - f_ref[vs]).max() <= 1e-10 * scale
        assert np.array_equal(f_tree[:vs.start], f_ref[:vs.start])


def test_dynamics_tree_refused_where_mimic_joints_stay_apart():
    from snakesim.framework.registry import default_registry
    from snakesim.framework.session import Session
    resolved = _session(2, "tree").resolved
    resolved.components["robot"].params["screw_pairs"] = "mimic_crba"
    with pytest.raises(Exception, match="dynamics = 'tree'"):
        Session(resolved, default_registry())


def test_first_order_share_as_a_diagonal():
    """The PID integral's share of the reduced matrix, −c² G_F D (P_v + c P_q), handed to the tree as a
    diagonal: equal to the dense kernel's where it is diagonal, refused (False) where it is not."""
    from snakesim.framework import linear_solve_kernels as kern
    rng = np.random.default_rng(3)
    nv, nF, q0 = 5, 4, 4                 # F states at 0..3, the owner's q at 4..8, v at 9..13
    n = q0 + 2 * nv
    Dinv = np.r_[rng.uniform(0.5, 1.0, nF), np.ones(2 * nv)]
    c = 0.02
    dof = np.array([1, 2, 3, 4])
    gf_r, gf_c, gf_v = dof, np.arange(nF), rng.uniform(-50, 50, nF)          # ∂τ_dof/∂F_i
    p_r = np.repeat(np.arange(nF), 2)                                          # Ḟ_i = e_i (q, v of its joint)
    p_c = np.column_stack([q0 + dof, q0 + nv + dof]).ravel()                   # rows sorted, as assemble()'s
    p_v = rng.uniform(-3, 3, 2 * nF)
    p_ptr = np.searchsorted(p_r, np.arange(n + 1))
    dense = np.zeros((nv, nv))
    z = np.zeros((nv, nv))
    kern.reduced_matrix(dense, z, z, z, c, q0, nv, Dinv, gf_r, gf_c, gf_v, p_ptr, p_c, p_v)
    diag = np.empty(nv)
    assert kern.reduced_diagonal(diag, c, q0, nv, Dinv, gf_r, gf_c, gf_v, p_ptr, p_c, p_v)
    assert np.allclose(np.diag(diag), dense, rtol=1e-14, atol=0.0) and np.abs(diag).max() > 0
    p_c2 = p_c.copy()
    p_c2[0] = q0 + 0                                                           # F_0 reads another joint
    assert not kern.reduced_diagonal(diag, c, q0, nv, Dinv, gf_r, gf_c, gf_v, p_ptr, p_c2, p_v)


@pytest.mark.parametrize("seed", range(4))
def test_symmetric_factor_solves_the_mass_matrix(seed):
    """factor_symmetric (the forward dynamics' elimination of M + diag(d) on upper triangles) solves M x = b
    as the dense solve does, and as the general factor does."""
    rng = np.random.default_rng(100 + seed)
    t = random_tree(rng)
    n, nv = t["order"].size, t["nv"]
    O = t["p"][t["order"][0]]
    J = link_jacobians(t)
    d = np.zeros(nv)
    d[6:] = rng.uniform(0.0, 0.3, nv - 6)
    M = sum(J[l].T @ spatial_inertia_at(t, l, O) @ J[l] for l in range(n)) + np.diag(d)
    op = TreeOp(t, np.zeros((n, 6, 6)), np.zeros((n, 6, 6)), np.zeros(n, np.bool_))
    U, D, Ia = np.zeros((nv, 6)), np.zeros(nv), np.zeros((n, 6, 6))
    lu, piv = np.zeros((6, 6)), np.zeros(6, np.int64)
    assert ask.factor_symmetric(t["order"], t["parent"], t["jtype"], t["vidx"], op.ptr, op.dof, t["R"], op.Iin, op.sig,
                                d, Ia, U, D, lu, piv)
    for _ in range(3):
        b = rng.standard_normal(nv)
        x = b.copy()
        ask.solve(t["order"], t["parent"], t["jtype"], t["vidx"], op.ptr, op.dof, t["R"], op.sig, U, U, D, lu, piv, x,
                  op.s1, op.s2, np.zeros(nv, np.bool_))
        x_ref = np.linalg.solve(M, b)
        assert np.abs(x - x_ref).max() <= 1e-10 * np.abs(x_ref).max()
        assert op.factor(0.0, d)
        assert np.abs(op.solve(b) - x).max() <= 1e-12 * np.abs(x_ref).max()
