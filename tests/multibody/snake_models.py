"""Small snake URDFs for the multibody tests (independent of snakesim.robots), and helpers.

``snake_urdf`` builds a tail plus N modules joined by pitch bend joints, each
module optionally with a twist joint (about the robot axis x), one or two
screws (two: a counter-rotating pair, the rear one ``<mimic multiplier=-1>``),
a massless sensor frame on a fixed joint, and an optional massive head on a
fixed joint. Bodies carry deliberately unsymmetric inertias and off-axis
centres of mass so no result holds by symmetry alone; screws are
axisymmetric about their spin axis, as the hardware's are.
"""

from __future__ import annotations


import numpy as np
import pytest

from snakesim.framework import Component, Input, Output, Params
from snakesim.framework.registry import build_registry

HEAD_COM = (0.06, 0.01, -0.02)


def _inertial(mass, com, ixx, iyy, izz, ixy=0.0, ixz=0.0, iyz=0.0):
    return (f'<inertial><origin xyz="{com[0]} {com[1]} {com[2]}" rpy="0.1 -0.2 0.3"/><mass value="{mass}"/>'
            f'<inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="{ixy}" ixz="{ixz}" iyz="{iyz}"/></inertial>')


def _screw_inertial(mass):
    # a thick tube about x: axisymmetric, COM on the axis
    return (f'<inertial><origin xyz="0 0 0"/><mass value="{mass}"/>'
            f'<inertia ixx="{0.012 * mass}" iyy="{0.009 * mass}" izz="{0.009 * mass}" ixy="0" ixz="0" iyz="0"/></inertial>')


def snake_urdf(modules: int = 3, screws: str = "pair", twist: bool = False, separate_pair: bool = False,
               head_mass: float = 0.0, frames: bool = True, rear_screw_mass: float = 1.6) -> str:
    links, joints = [], []
    links.append(f'<link name="tail">{_inertial(1.2, (0.05, 0.004, -0.003), 0.004, 0.006, 0.007, 0.0002)}</link>')
    prev = "tail"
    for i in range(modules):
        s = f"{i:02d}"
        body = f"module_{s}"
        if twist:
            links.append(f'<link name="knuckle_{s}">{_inertial(0.8, (0.02, 0.0, 0.003), 0.002, 0.003, 0.003)}</link>')
            joints.append(f'<joint name="bend_{s}" type="revolute"><parent link="{prev}"/><child link="knuckle_{s}"/>'
                          f'<origin xyz="{0.12 if i == 0 else 0.4} 0 0"/><axis xyz="0 1 0"/>'
                          f'<limit lower="-1" upper="1" effort="100" velocity="1"/></joint>')
            joints.append(f'<joint name="twist_{s}" type="revolute"><parent link="knuckle_{s}"/><child link="{body}"/>'
                          f'<origin xyz="0.05 0 0"/><axis xyz="1 0 0"/>'
                          f'<limit lower="-2" upper="2" effort="50" velocity="1"/></joint>')
        else:
            joints.append(f'<joint name="bend_{s}" type="revolute"><parent link="{prev}"/><child link="{body}"/>'
                          f'<origin xyz="{0.12 if i == 0 else 0.4} 0 0"/><axis xyz="0 1 0"/>'
                          f'<limit lower="-1" upper="1" effort="100" velocity="1"/></joint>')
        links.append(f'<link name="{body}">{_inertial(3.0 + 0.3 * i, (0.17, 0.012, -0.008), 0.011, 0.04, 0.043, 0.0011, -0.0007, 0.0004)}</link>')
        rear_parent = body
        if separate_pair:
            # the rear screw sits behind a second twist joint about the screw axis
            links.append(f'<link name="aft_{s}">{_inertial(0.6, (0.03, 0.0, 0.0), 0.001, 0.002, 0.002)}</link>')
            joints.append(f'<joint name="aft_twist_{s}" type="revolute"><parent link="{body}"/><child link="aft_{s}"/>'
                          f'<origin xyz="0.25 0 0"/><axis xyz="1 0 0"/>'
                          f'<limit lower="-2" upper="2" effort="50" velocity="1"/></joint>')
            rear_parent = f"aft_{s}"
        if screws in ("pair", "front"):
            links.append(f'<link name="screw_front_link_{s}">{_screw_inertial(1.6)}</link>')
            joints.append(f'<joint name="screw_front_{s}" type="continuous"><parent link="{body}"/>'
                          f'<child link="screw_front_link_{s}"/><origin xyz="0.28 0 0"/><axis xyz="1 0 0"/>'
                          f'<limit effort="30" velocity="10"/></joint>')
        if screws == "pair":
            links.append(f'<link name="screw_rear_link_{s}">{_screw_inertial(rear_screw_mass)}</link>')
            x = 0.05 if separate_pair else 0.1
            joints.append(f'<joint name="screw_rear_{s}" type="continuous"><parent link="{rear_parent}"/>'
                          f'<child link="screw_rear_link_{s}"/><origin xyz="{x} 0 0"/><axis xyz="1 0 0"/>'
                          f'<limit effort="30" velocity="10"/><mimic joint="screw_front_{s}" multiplier="-1"/></joint>')
        if frames:
            links.append(f'<link name="sensor_{s}"/>')
            joints.append(f'<joint name="sensor_joint_{s}" type="fixed"><parent link="{body}"/><child link="sensor_{s}"/>'
                          f'<origin xyz="0.2 0 0.07" rpy="0.3 0.1 -0.4"/></joint>')
        prev = body
    if head_mass > 0:
        c = HEAD_COM
        links.append(f'<link name="head"><inertial><origin xyz="{c[0]} {c[1]} {c[2]}"/><mass value="{head_mass}"/>'
                     f'<inertia ixx="0.003" iyy="0.005" izz="0.006" ixy="0" ixz="0" iyz="0"/></inertial></link>')
        joints.append(f'<joint name="head_joint" type="fixed"><parent link="{prev}"/><child link="head"/>'
                      f'<origin xyz="0.4 0 0" rpy="0 0.2 0"/></joint>')
        links.append('<link name="camera"/>')
        joints.append('<joint name="camera_joint" type="fixed"><parent link="head"/><child link="camera"/>'
                      '<origin xyz="0.1 0 0.03"/></joint>')
    return '<robot name="test_snake">' + "".join(links) + "".join(joints) + "</robot>"


class AnchorSpringParams(Params):
    nl: int
    link: int = 0
    k: float = 1000.0                     # N/m
    anchor: tuple[float, float, float] = (0.0, 0.0, 0.0)


class AnchorSpring(Component[AnchorSpringParams]):
    """A linear spring from a world anchor to one link's origin (a conservative tether, test only)."""

    type_name = "test_anchor_spring"
    Params = AnchorSpringParams
    poses = Input(shape=("nl", 7), unit=None)
    wrenches = Output(shape=("nl", 6), unit=None, feedthrough=("poses",))

    def output(self, t, x, u, y):
        y.wrenches[:] = 0.0
        y.wrenches[self.p.link, :3] = -self.p.k * (u.poses[self.p.link, :3] - np.asarray(self.p.anchor))

    def potential(self, poses_row) -> np.ndarray:
        d = poses_row[..., :3] - np.asarray(self.p.anchor)
        return 0.5 * self.p.k * (d * d).sum(axis=-1)


@pytest.fixture(scope="session")
def registry():
    reg = build_registry(load_entry_points=False)
    reg.add_component(AnchorSpring)
    return reg


def random_state(model, rng, spread=1.5):
    import pinocchio as pin

    q = pin.randomConfiguration(model, -spread * np.ones(model.nq), spread * np.ones(model.nq))
    return q, rng.standard_normal(model.nv)


def make_harness(urdf: str | None = None, **params):
    from snakesim.components.multibody import Multibody
    from snakesim.framework import Harness

    if urdf is not None:
        params["urdf"] = urdf
    return Harness(Multibody, params, name="robot")


def set_state(h, q, v, tau=None, wrenches=None, gravity=None):
    h.x[:] = np.concatenate([q, v])
    if tau is not None:
        h.inputs.tau = tau
    if wrenches is not None:
        h.inputs.wrenches = wrenches
    if gravity is not None:
        h.inputs.gravity = gravity


def reference_model(urdf: str):
    """Pinocchio's own URDF parser, mimic joints honoured: the independent reference model."""
    import pinocchio as pin

    model = pin.buildModelFromXML(urdf, pin.JointModelFreeFlyer(), True)
    return model, model.createData()


def coordinate_maps(h, ref_model):
    """(q index map, v index map): component index -> reference index, matched by joint name."""
    cm = h.c.dyn.model
    qmap, vmap = np.zeros(cm.nq, dtype=int), np.zeros(cm.nv, dtype=int)
    for jid in range(1, cm.njoints):
        cj = cm.joints[jid]
        if cj.nv == 0:
            continue
        rj = ref_model.joints[ref_model.getJointId(cm.names[jid])]
        assert (rj.nq, rj.nv) == (cj.nq, cj.nv)
        qmap[cj.idx_q:cj.idx_q + cj.nq] = np.arange(rj.idx_q, rj.idx_q + rj.nq)
        vmap[cj.idx_v:cj.idx_v + cj.nv] = np.arange(rj.idx_v, rj.idx_v + rj.nv)
    return qmap, vmap
