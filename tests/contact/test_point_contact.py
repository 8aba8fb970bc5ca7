"""The point_contact component alone (harness), against the numpy kernel."""

import numpy as np

from snakesim.components.contact import contact_forces
from snakesim.components.contact.point_contact import PointContact
from snakesim.framework import Harness


def test_point_contact_matches_kernel():
    p = dict(n=3, material=dict(mu=0.5, ev_a=3.0, ev_b=0.0, k=1e4, c=0.0), v_eps=0.0)
    h = Harness(PointContact, p)
    depth = np.array([0.001, -0.01, 0.002])
    normal = np.repeat([[0.0, 0.0, 1.0]], 3, 0)
    vel = np.array([[3.0, 4.0, 0.0], [1.0, 0, 0], [0, 1.0, 0]])
    ev = np.repeat([[1.0, 0, 0]], 3, 0)
    h.inputs.depth, h.inputs.normal, h.inputs.velocity, h.inputs.thread_dir = depth, normal, vel, ev
    out = h.outputs()
    np.testing.assert_allclose(out["force"][0], [-9.0, -4.0, 10.0])      # the eq. 6 hand case
    f, fn = contact_forces(depth, normal, vel, ev, 1e4, 0.0, 0.5, 3.0)
    np.testing.assert_allclose(out["force"], f, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(out["normal_force"], fn, rtol=1e-12, atol=1e-12)
