"""The end of every sampled contact evaluation, whatever its owners (screws, body pieces): the counters,
the contact count and total normal force outputs and, when tracked, the inputs it saw
(``count_evaluation``).

work.counts: [evaluations, owners tested, rows queried, active owners, rows m of the last evaluation].
"""

from __future__ import annotations

from numba import njit

from ..kernel_reductions import np_sum


@njit(cache=True)
def count_evaluation(work, ports, n_active, m, n_contact, owner_fn):
    """Counters into work.counts, ports.contacts = n_contact, ports.normal_force = Σ owner_fn (the per-screw
    or per-link normal forces, summed as NumPy would) and, when work.track, the poses and velocities seen
    (so the contact set can tell whether the last evaluation describes its inputs)."""
    c = work.counts
    c[0] += 1
    c[1] += n_active
    c[2] += m
    c[3] = n_active
    c[4] = m
    ports.contacts[0] = n_contact
    ports.normal_force[0] = np_sum(owner_fn)
    if work.track:
        work.seen_poses[:] = ports.poses
        work.seen_vels[:] = ports.vels
