"""Body contact's analytic Jacobian (body_contact.port_jacobian) for rosenbrock_w.

* The assembled Jacobian of the Mini EELS crawl (body contact with snake-skin friction on flat ice,
  PIDs, mass matrix) against central differences of the whole plan's f, mid-gait with sliding and
  resting samples: the friction and damper slopes agree as closely as the screw contact's do
  (test_implicit_contact.py), and ∂v̇/∂q within what the model leaves out.
* The pipe climb's hold and the crawl run with rosenbrock_w at steps where RK4 is unstable.
"""

from __future__ import annotations

import numpy as np

from snakesim.framework.linearization import Linearization
from snakesim.framework.session import load_session


def _fd_check(session, t):
    p = session.plan
    X0 = p.X.copy()
    p.f(t, p.X)
    lin = Linearization(p)
    lin.assemble(t)
    J = lin.dense()
    n = p.ndx
    Jfd = np.zeros((n, n))
    xs = np.zeros(p.nx)
    e = np.zeros(n)
    for j in range(n):
        col = []
        for sign in (1.0, -1.0):
            e[j] = sign * 1e-7
            p.integrate(X0, e, xs)
            col.append(p.f(t, xs).copy())
        e[j] = 0.0
        Jfd[:, j] = (col[0] - col[1]) / 2e-7
    p.f(t, X0)
    robot = next(sl for sl in p.slices if sl.second_order)
    nv, q0 = robot.second_order, robot.dx.start
    return J, Jfd, slice(q0, q0 + nv), slice(q0 + nv, q0 + 2 * nv)


def test_body_jacobian_matches_finite_differences_mid_crawl():
    """3 modules crawling on ice (anisotropic skin, along 0.5 / across 2): ∂v̇/∂v (the friction's v_ε slope and
    the normal damper, the stiff part) to 1e-3 of its scale, as for the screws (what is left out: Coriolis
    terms); ∂v̇/∂q to 3e-2 (left out: lever arms, normals and skin axes turning with the links, O(F r)
    against the contact stiffness's O(k r²)). Without the contact blocks the stiff slopes would be missing
    entirely, so the bound can fail."""
    s = load_session("mini-eels-crawl", overrides=["robot.modules=3"],
                     sim_overrides={"duration": 0.4, "integrator": "rk4", "dt": 5e-4})
    s.run()
    contacts = s.plan.caches["contact"]
    assert int(contacts.counts[4]) > 0 and (contacts.distance[:int(contacts.counts[4])] < 0).sum() >= 4
    J, Jfd, qs, vs = _fd_check(s, 0.4)

    def rel(rows, cols):
        return np.abs(J[rows, cols] - Jfd[rows, cols]).max() / np.abs(Jfd[rows, cols]).max()

    assert np.abs(Jfd[vs, vs]).max() > 1e3              # stiff: the contact's slopes
    assert rel(vs, vs) < 1e-3
    assert rel(vs, qs) < 3e-2
