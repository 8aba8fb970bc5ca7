"""A neutral, URDF-shaped description of a robot: links, joints, shapes.

The design builder fills these plain records and the URDF writer serialises
them; neither knows about the other's concerns (EELS topology vs XML).

Conventions (all SI: m, rad, kg, N·m, rad/s):

* a joint's ``origin`` is the pose of the child link frame in the parent link
  frame at zero joint position (URDF semantics);
* a shape's ``pose`` is its pose in its link frame;
* URDF cylinders are along their local z axis; :func:`cylinder_along_x`
  rotates them onto the x axis, the robot axis of every EELS body.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal, Union

from .mass_properties import MassProperties

Vec3 = tuple[float, float, float]

JointType = Literal["revolute", "continuous", "prismatic", "fixed", "floating", "planar"]


@dataclass(frozen=True)
class Pose:
    """Translation (m) and roll-pitch-yaw (rad, URDF fixed-axis XYZ order)."""

    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Cylinder:
    radius: float
    length: float


@dataclass(frozen=True)
class Box:
    size: Vec3


@dataclass(frozen=True)
class Sphere:
    radius: float


@dataclass(frozen=True)
class Mesh:
    """A mesh file; ``filename`` is written verbatim into the URDF (relative
    to the URDF file's folder for generated robots)."""

    filename: str


Geometry = Union[Cylinder, Box, Sphere, Mesh]


@dataclass(frozen=True)
class Shape:
    geometry: Geometry
    pose: Pose = Pose()
    material: str | None = None  # visual colour name; ignored for collisions


@dataclass(frozen=True)
class Material:
    name: str
    rgba: tuple[float, float, float, float]


@dataclass
class Link:
    """A body. ``inertial`` is None for massless frames (sensor frames), which
    URDF parsers turn into plain frames of the parent body."""

    name: str
    inertial: MassProperties | None = None
    visuals: list[Shape] = field(default_factory=list)
    collisions: list[Shape] = field(default_factory=list)


@dataclass(frozen=True)
class Limit:
    """Position limits (rad; None for continuous joints), effort (N·m) and
    velocity (rad/s) limits."""

    effort: float
    velocity: float
    lower: float | None = None
    upper: float | None = None


@dataclass(frozen=True)
class Mimic:
    """q_this = multiplier * q_joint + offset."""

    joint: str
    multiplier: float
    offset: float = 0.0


@dataclass
class Joint:
    name: str
    type: JointType
    parent: str
    child: str
    origin: Pose = Pose()
    axis: Vec3 | None = None  # in the child (= joint) frame; None for fixed joints
    limit: Limit | None = None
    mimic: Mimic | None = None


@dataclass
class KinematicTree:
    """Links in creation order (root first) and the joints connecting them."""

    name: str
    links: list[Link] = field(default_factory=list)
    joints: list[Joint] = field(default_factory=list)
    materials: list[Material] = field(default_factory=list)

    @property
    def root(self) -> str:
        return self.links[0].name

    def add_link(self, link: Link) -> Link:
        self.links.append(link)
        return link

    def add_joint(self, joint: Joint) -> Joint:
        self.joints.append(joint)
        return joint


def cylinder_along_x(radius: float, length: float, center_x: float = 0.0, material: str | None = None) -> Shape:
    """A cylinder whose axis is the link's x axis, centred at ``center_x``.

    Rotating the URDF cylinder (axis z) by +pi/2 about y maps z onto +x.
    """
    return Shape(Cylinder(radius, length), Pose((center_x, 0.0, 0.0), (0.0, math.pi / 2, 0.0)), material)
