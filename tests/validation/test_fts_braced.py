"""EELS 1.5's force-torque sensors see the wall contact forces (paper 2.2.4: the FTS array tells a
vertical-mobility controller about the robot's contact with the walls).

Braced between the walls of walls-brace-climb.yaml, the part D_k of the robot beyond sensor k
(its URDF subtree: the modules toward the front) is pushed by the walls (the screw contact's
per-link wrenches) and pulled by gravity, and the sensor carries the rest. Newton for D_k:

    R_k f_k + Σ_{l∈D_k} F_c,l + m_{D_k} g = Σ_{l∈D_k} m_l a_c,l

with f_k the sensor's force (parent on child, sensor frame R_k), a_c,l the acceleration of link
l's centre of mass (from the recorded link accelerations, a_o + α×r + ω×(ω×r)). So the reading
equals minus the distal contact forces and weight, up to the distal links' inertia, computed
from the same samples (and under 1 % of those loads: the brace is static).
"""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.multibody.pose_quaternions import rotation_matrices
from snakesim.framework.assembly import ComponentSpec

from validation_scenes import run

G = np.array([0.0, 0.0, -9.81])


def _with_fts(resolved):
    resolved.components["fts"] = ComponentSpec(type="force_torque_sensors")
    resolved.connections.append(("robot.joint_wrenches", "fts.joint_wrenches", None))
    resolved.record += [("fts.wrench", None), ("robot.link_accelerations", None), ("robot.link_velocities", None)]


@pytest.fixture(scope="module")
def braced():
    return run("walls-brace-climb", [], {"duration": 3.0}, patch=_with_fts)


def test_each_sensor_carries_the_wall_forces_and_weight_beyond_it(braced):
    s, r = braced
    assert r.summary["completed"], r.summary
    robot = s.plan.components["robot"].robot
    links, tree = list(robot.links), robot.tree
    by_name = {ln.name: ln for ln in tree.links}
    mass = np.array([by_name[n].mass for n in links])
    com = np.array([by_name[n].com for n in links])
    names = s.plan.components["fts"].sensor_names
    n = len(r["t"])
    poses = r["robot.link_poses"].reshape(n, -1, 7)
    Fc = r["contact.wrenches"].reshape(n, -1, 6)[:, :, :3]
    acc = r["robot.link_accelerations"].reshape(n, -1, 6)
    vel = r["robot.link_velocities"].reshape(n, -1, 6)
    W = r["fts.wrench"].reshape(n, len(names), 6)
    late = r["t"] >= 2.0                                            # braced: the load loop has settled
    assert late.sum() >= 10
    checked = 0
    for k, cut in enumerate(names):
        fts_link = tree.joint_by_name[cut].child
        D = [links.index(l) for l in tree.subtree(fts_link)]
        for i in np.flatnonzero(late):
            R = rotation_matrices(poses[i, :, 3:])
            r_c = np.einsum("lij,lj->li", R, com)                      # link origin -> COM, world
            w_, a_, al = vel[i, :, 3:], acc[i, :, :3], acc[i, :, 3:]
            a_c = a_ + np.cross(al, r_c) + np.cross(w_, np.cross(w_, r_c))
            sensor = R[links.index(fts_link)] @ W[i, k, :3]
            contact = Fc[i, D].sum(axis=0)
            weight = mass[D].sum() * G
            inertia = (mass[D, None] * a_c[D]).sum(axis=0)
            # Newton for the distal part, to the float rounding of the sums (forces of ~100 N)
            np.testing.assert_allclose(sensor + contact + weight, inertia, atol=1e-6 * np.abs(contact).sum() + 1e-6)
            # and it is static: the inertia is under 1 % of the loads the sensor carries
            assert np.linalg.norm(inertia) < 0.01 * (np.linalg.norm(contact) + np.linalg.norm(weight))
            checked += 1
    assert checked == len(names) * late.sum()
