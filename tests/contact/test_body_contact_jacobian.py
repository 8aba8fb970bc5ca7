"""Body contact's analytic Jacobian (body_contact.port_jacobian) for rosenbrock_w.

* The assembled Jacobian of the Mini EELS crawl (body contact with snake-skin friction on flat ice,
  PIDs, mass matrix) against central differences of the whole plan's f, mid-gait with sliding and
  resting samples: the friction and damper slopes agree as closely as the screw contact's do
  (test_implicit_contact.py), and ∂v̇/∂q within what the model leaves out.
* The pipe climb's hold and the crawl run with rosenbrock_w at steps where RK4 is unstable.
"""

from __future__ import annotations

import numpy as np

from snakesim.framework.session import load_session

from jacobian_check import analytic_and_fd_jacobian


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
    J, Jfd, qs, vs = analytic_and_fd_jacobian(s.plan, 0.4)

    def rel(rows, cols):
        return np.abs(J[rows, cols] - Jfd[rows, cols]).max() / np.abs(Jfd[rows, cols]).max()

    assert np.abs(Jfd[vs, vs]).max() > 1e3              # stiff: the contact's slopes
    assert rel(vs, vs) < 1e-3
    assert rel(vs, qs) < 3e-2
