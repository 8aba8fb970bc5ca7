"""A one-joint robot with closed-form dynamics (zero gravity)."""

from __future__ import annotations

from snakesim.components.multibody.robot_model import RobotModel

J_LINK = 0.5          # kg·m², link inertia about the hinge axis (z)
J_BASE = 50.0         # kg·m², base inertia about z: the hinge reacts against a free base


def hinge_urdf(j_link: float = J_LINK, j_base: float = J_BASE, continuous: bool = False) -> str:
    """Free base + one link on a hinge about z through both centres of mass: in zero gravity the
    relative angle obeys J_eff θ̈ = τ with J_eff = J_link·J_base/(J_link + J_base), exactly."""
    kind = "continuous" if continuous else "revolute"
    limit = '<limit effort="1000" velocity="100"/>' if continuous else \
        '<limit lower="-3" upper="3" effort="1000" velocity="100"/>'
    return (f'<robot name="hinge"><link name="base"><inertial><origin xyz="0 0 0"/><mass value="20"/>'
            f'<inertia ixx="{j_base}" iyy="{j_base}" izz="{j_base}" ixy="0" ixz="0" iyz="0"/></inertial></link>'
            f'<link name="arm"><inertial><origin xyz="0 0 0"/><mass value="2"/>'
            f'<inertia ixx="0.3" iyy="0.4" izz="{j_link}" ixy="0" ixz="0" iyz="0"/></inertial></link>'
            f'<joint name="hinge" type="{kind}"><parent link="base"/><child link="arm"/>'
            f'<origin xyz="0 0 0"/><axis xyz="0 0 1"/>{limit}</joint></robot>')


def hinge_robot(j_link: float = J_LINK, j_base: float = J_BASE, continuous: bool = False) -> RobotModel:
    """The hinge as the RobotModel a multibody would provide (what a component alone is handed)."""
    return RobotModel.load(urdf=hinge_urdf(j_link, j_base, continuous))


def j_eff(j_link: float = J_LINK, j_base: float = J_BASE) -> float:
    return j_link * j_base / (j_link + j_base)
