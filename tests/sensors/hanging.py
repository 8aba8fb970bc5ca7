"""EELS 1.5 in static equilibrium, hanging from a tether at its front or standing on its tail.

Masses and centres of mass come from the URDF text (xml), not from the
multibody: the expected sensor readings are computed independently. The
sensors and the tether are handed the multibody's RobotModel, as an assembly
binds them.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from snakesim.components.multibody import Multibody
from snakesim.components.sensors import ForceTorqueSensors, Imu
from snakesim.components.tethers import Tethers
from snakesim.framework import Harness

G = np.array([0.0, 0.0, -9.81])
ROBOT = {"design": "eels-1.5"}
TIE_LINK, TIE_OFFSET = "module_03", (0.3, 0.0, 0.0)
K, REST = 2.0e4, 1.0


def urdf_masses(text):
    """(link -> mass, link -> COM in link frame, child link -> parent link)."""
    root = ET.fromstring(text)
    mass, com, parent = {}, {}, {}
    for ln in root.findall("link"):
        m = ln.find("inertial/mass")
        o = ln.find("inertial/origin")
        mass[ln.get("name")] = float(m.get("value")) if m is not None else 0.0
        com[ln.get("name")] = np.array([float(v) for v in o.get("xyz").split()]) if o is not None else np.zeros(3)
    for j in root.findall("joint"):
        parent[j.find("child").get("link")] = j.find("parent").get("link")
    return mass, com, parent


def subtree(link, parent):
    out = {link}
    changed = True
    while changed:
        changed = False
        for c, p in parent.items():
            if p in out and c not in out:
                out.add(c)
                changed = True
    return out


def _rotation_taking(a, b):
    """A rotation R with R a = b (unit vectors)."""
    v, c = np.cross(a, b), float(a @ b)
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1.0 + c)


def _quat(R):
    import pinocchio as pin

    q = pin.Quaternion(R)
    return np.array([q.x, q.y, q.z, q.w])


def equilibrium(support: str):
    """support "tether" (hanging from the front) or "tail" (a wrench on the tail holds it up).

    Returns dict: robot/fts/imu harnesses evaluated in equilibrium, tether harness (or None), masses.
    """
    robot = Harness(Multibody, {**ROBOT}, name="robot")
    model = robot.c.robot
    mass, com, parent = urdf_masses(model.urdf)
    M = sum(mass.values())
    links = list(model.links)
    x0 = robot.x.copy()
    out = robot.outputs()
    P, Rl = out["link_poses"][:, :3], out["link_rotations"]            # identity base at the origin
    c = sum(mass[n] * (P[i] + Rl[i] @ com[n]) for i, n in enumerate(links)) / M
    tie = P[links.index(TIE_LINK)] + Rl[links.index(TIE_LINK)] @ np.array(TIE_OFFSET)
    # orientation: hanging, the centre of mass lies straight below the tie point
    R = _rotation_taking((c - tie) / np.linalg.norm(c - tie), np.array([0.0, 0.0, -1.0]))
    x = x0.copy()
    x[:3] = -R @ tie                                                  # the tie point at the world origin
    x[3:7] = _quat(R)
    robot.x[:] = x
    tether = None
    out = robot.outputs()
    if support == "tether":
        tether = Harness(Tethers, {"tethers": [{"link": TIE_LINK, "offset": TIE_OFFSET, "stiffness": K,
                                                "damping": 50.0, "rest_length": REST,
                                                "anchor": (0.0, 0.0, REST + M * 9.81 / K)}]},
                         uses={"robot": model})
        for k in ("link_rotations", "link_poses", "link_velocities"):
            tether.set_input(k, out[k])
        W = tether.outputs()["wrenches"]
    else:
        W = np.zeros((len(links), 6))
        o = out["link_poses"][0, :3]
        cw = x[:3] + R @ c
        W[0, :3] = -M * G
        W[0, 3:] = np.cross(cw - o, -M * G)
    robot.inputs.wrenches = W
    # joint torques that hold the shape: a is affine in tau, solve a_joints = 0
    nj = model.nj
    robot.inputs.tau = np.zeros(nj)
    a0 = robot.outputs()["a"][6:].copy()
    B = np.zeros((nj, nj))
    for j in range(nj):
        e = np.zeros(nj)
        e[j] = 1.0
        robot.inputs.tau = e
        B[:, j] = robot.outputs()["a"][6:] - a0
    robot.inputs.tau = np.linalg.solve(B, -a0)
    out = robot.outputs()
    fts = Harness(ForceTorqueSensors, {}, uses={"robot": model})        # default cuts: fts_joint_*
    fts.inputs.joint_wrenches = out["joint_wrenches"]
    return {"robot": robot, "model": model, "out": out, "fts": fts, "tether": tether, "mass": mass, "com": com,
            "parent": parent, "M": M, "links": links}


def imu_at(eq, link, offset=(0.0, 0.0, 0.0), **params):
    imu = Harness(Imu, {"link": link, "offset": offset, **params}, uses={"robot": eq["model"]})
    for k in ("link_rotations", "link_poses", "link_velocities", "link_accelerations"):
        imu.set_input(k, eq["out"][k])
    return imu
