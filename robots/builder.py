"""Builds the kinematic tree and metadata of one EELS design with N modules.

The topology rules live in :mod:`snakesim.robots.designs` (module docstring);
this module places the bodies. Link frames, all with x along the robot axis
(tail -> head) at zero joint positions:

* ``tail``: origin at the tail tip; the body spans x in [0, tail_length];
  ``bend_00`` sits at its front face.
* ``knuckle_i``: origin on the bend axis; spans [0, knuckle_length]; the
  twist axis is at its front face.
* ``module_i``: origin on the twist axis (designs with twist joints) or the
  bend axis (without); spans [0, body_length]; what follows (next bend, the
  next force-torque sensor, the cross bar or the head) hangs from its front
  face at x = body_length.
* ``screw_*_link_i``: origin at the screw centre on the axis; the screw spans
  x in [-length/2, length/2]. The rear screw of a module is centred at a
  quarter of the body, the front screw at three quarters (front-only designs
  keep the front slot and leave the rear one empty).
* ``fts_i``: origin at the transducer's sensing frame, its mid-plane;
  ``bend_i`` is at x = +fts_length/2.
* ``cross_bar``: origin at its rear face on the axis; ``avionics_box`` sits on
  top (+z).
* ``head`` / ``head_cap``: origin at the rear face, spanning [0, head_length].

Bend-axis spacing is ``module_length`` = knuckle + body + force-torque sensor.

Masses: the design's nominal masses hold at its nominal dimensions; when
``module_length`` or ``screw_radius`` change, each body's mass scales with its
envelope volume (constant effective density), so shorter modules are lighter.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from . import naming
from .designs import Design
from .kinematic_tree import (
    Box, Joint, KinematicTree, Limit, Link, Material, Mesh, Mimic, Pose, Shape, Sphere, cylinder_along_x,
)
from .mass_properties import MassProperties, is_physical, solid_box, solid_cylinder_x, tube_x
from .parameters import RobotParameters
from .screw_mesh import ScrewGeometry

MESH_PREFIX = "../meshes/"  # mesh file names are relative to the URDF: urdf/ and meshes/ are siblings

MATERIALS = (
    Material("shell", (0.92, 0.92, 0.90, 1.0)),
    Material("joint_housing", (0.25, 0.25, 0.28, 1.0)),
    Material("screw", (0.70, 0.72, 0.75, 1.0)),
    Material("head", (0.95, 0.55, 0.10, 1.0)),
    Material("sensor", (0.95, 0.85, 0.15, 1.0)),
    Material("avionics", (0.15, 0.35, 0.75, 1.0)),
)

_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


@dataclass
class BuiltRobot:
    """A generated robot: tree, sidecar metadata, and the screw meshes its URDF
    references (file name -> geometry to generate it from)."""

    tree: KinematicTree
    metadata: dict[str, Any]
    screw_meshes: dict[str, ScrewGeometry] = field(default_factory=dict)


@dataclass(frozen=True)
class _Geometry:
    """Derived sizes (m) for given module length and outer radius."""

    module_length: float
    outer_radius: float  # screw blade tip radius; body radius when screwless
    core_radius: float  # screw drum radius = body radius
    tail_length: float
    knuckle_length: float
    fts_length: float
    body_length: float
    screw_length: float
    head_length: float

    @property
    def body_radius(self) -> float:
        return self.core_radius

    @property
    def fts_radius(self) -> float:
        return 0.8 * self.core_radius

    def screw_center(self, position: str) -> float:
        return self.body_length * (0.75 if position == "front" else 0.25)

    # Envelope volumes (m³, up to the common factor pi) for mass scaling.
    def volume(self, body: str) -> float:
        r2 = self.core_radius**2
        return {
            "tail": r2 * self.tail_length,
            "knuckle": r2 * self.knuckle_length,
            "module_body": r2 * self.body_length,
            "screw": (self.outer_radius**2 - r2) * self.screw_length,
            "head": r2 * self.head_length,
            "fts": self.fts_radius**2 * self.fts_length,
        }[body]


def _geometry(design: Design, module_length: float, outer_radius: float) -> _Geometry:
    d = design.dimensions
    body_length = module_length - d.knuckle_length - d.fts_length
    return _Geometry(
        module_length=module_length,
        outer_radius=outer_radius,
        core_radius=d.core_ratio * outer_radius,
        tail_length=d.tail_length,
        knuckle_length=d.knuckle_length,
        fts_length=d.fts_length,
        body_length=body_length,
        # each screw gets half the body, less an axial gap at both of its ends
        screw_length=body_length / 2 - 2 * d.screw_gap,
        head_length=d.head_length,
    )


class _Builder:
    def __init__(self, design: Design, params: RobotParameters):
        self.design = design
        self.params = params
        outer = params.screw_radius if design.has_screws else design.dimensions.outer_radius
        self.geo = _geometry(design, params.module_length, outer)
        self.nominal = _geometry(design, design.dimensions.module_length, design.dimensions.outer_radius)
        self.tree = KinematicTree(name=design.name, materials=list(MATERIALS))
        self.screw_meshes: dict[str, ScrewGeometry] = {}
        self.meta_modules: list[dict[str, Any]] = []
        self.meta_screws: list[dict[str, Any]] = []
        self.meta_pairs: list[dict[str, Any]] = []
        self.meta_fts: list[dict[str, Any]] = []

    # ---- mass helpers -------------------------------------------------
    def _mass(self, body: str) -> float:
        nominal = getattr(self.design.masses, body)
        return nominal * self.geo.volume(body) / self.nominal.volume(body)

    def _cylinder_link(self, name: str, body: str, radius: float, length: float, material: str,
                       collide: bool = True) -> Link:
        """A solid cylinder along x spanning [0, length] of the link frame."""
        mass = self._mass(body)
        shape = cylinder_along_x(radius, length, length / 2, material)
        return self.tree.add_link(Link(
            name,
            MassProperties(mass, (length / 2, 0.0, 0.0), solid_cylinder_x(mass, radius, length)),
            visuals=[shape],
            collisions=[cylinder_along_x(radius, length, length / 2)] if collide else [],
        ))

    # ---- topology -----------------------------------------------------
    def build(self) -> BuiltRobot:
        g, n = self.geo, self.params.modules
        self._cylinder_link(naming.TAIL, "tail", g.body_radius, g.tail_length, "joint_housing")
        parent, attach_x = naming.TAIL, g.tail_length
        cross_bar_after = n // 2 - 1  # the cross bar follows this module (-1: the tail)
        if self.design.cross_bar and cross_bar_after < 0:
            parent, attach_x = self._cross_bar(parent, attach_x)
        for i in range(n):
            parent, attach_x = self._module(i, parent, attach_x)
            if self.design.cross_bar and i == cross_bar_after:
                parent, attach_x = self._cross_bar(parent, attach_x)
        if self.design.head == "perception" and self.params.head:
            self._perception_head(parent, attach_x)
        elif self.design.head == "cap" and self.params.head:
            self._head_cap(parent, attach_x)
        for link in self.tree.links:  # guards edits to the nominal numbers, e.g. a zero mass
            m = link.inertial
            if m is not None and not is_physical(m.mass, m.tensor()):
                raise ValueError(f"{self.design.name}: link {link.name!r} has unphysical mass properties {m}")
        return BuiltRobot(self.tree, self._metadata(), self.screw_meshes)

    def _module(self, i: int, parent: str, attach_x: float) -> tuple[str, float]:
        """Adds module i hanging from ``parent`` at x = ``attach_x``; returns
        the body and x at which the next element attaches."""
        d, g, lim = self.design, self.geo, self.design.limits
        bodies: list[str] = []
        fts = None
        if d.force_torque_sensors and i > 0:
            fts = self._force_torque_sensor(i, parent, attach_x)
            bodies.append(fts["link"])
            parent, attach_x = fts["link"], g.fts_length / 2

        bend_axis = "y" if d.bend_axes == "pitch" or i % 2 == 0 else "z"
        bend_child = naming.knuckle_link(i) if d.twist else naming.module_link(i)
        if d.twist:
            self._cylinder_link(bend_child, "knuckle", g.body_radius, g.knuckle_length, "joint_housing")
            bodies.append(bend_child)
        self.tree.add_joint(Joint(
            naming.bend_joint(i), "revolute", parent, bend_child, Pose((attach_x, 0.0, 0.0)), _AXES[bend_axis],
            Limit(lim.bend_effort, lim.bend_velocity, -lim.bend_range, lim.bend_range),
        ))
        twist = None
        if d.twist:
            twist = naming.twist_joint(i)
            self.tree.add_joint(Joint(
                twist, "revolute", bend_child, naming.module_link(i), Pose((g.knuckle_length, 0.0, 0.0)),
                _AXES["x"], Limit(lim.twist_effort, lim.twist_velocity, -lim.twist_range, lim.twist_range),
            ))
        body = naming.module_link(i)
        self._cylinder_link(body, "module_body", g.body_radius, g.body_length, "shell")
        bodies.append(body)

        positions = {"pair": ("front", "rear"), "front": ("front",), "none": ()}[d.screws]
        screw_joints = [self._screw(i, body, position) for position in positions]
        bodies += [naming.screw_link(p, i) for p in positions]
        if d.screws == "pair":
            self.meta_pairs.append({
                "front": naming.screw_joint("front", i), "rear": naming.screw_joint("rear", i),
                "body": body, "multiplier": -1.0,
            })
        self.meta_modules.append({
            "index": i,
            "bodies": bodies,
            "bend_joint": naming.bend_joint(i),
            "bend_axis": bend_axis,
            "twist_joint": twist,
            "screw_joints": screw_joints,
            "force_torque_sensor": fts["link"] if fts else None,
        })
        return body, g.body_length

    def _screw(self, i: int, body: str, position: str) -> str:
        g, p, lim = self.geo, self.params, self.design.limits
        hand = p.hand if position == "front" else _other_hand(p.hand)
        shape = ScrewGeometry(
            hand=hand, lead_angle=p.lead_angle, outer_radius=g.outer_radius, core_radius=g.core_radius,
            length=g.screw_length, starts=self.design.dimensions.screw_starts,
            blade_thickness=self.design.dimensions.blade_thickness,
        ).quantized()
        mesh_file = shape.filename()
        self.screw_meshes[mesh_file] = shape
        mass = self._mass("screw")
        link, joint = naming.screw_link(position, i), naming.screw_joint(position, i)
        self.tree.add_link(Link(
            link,
            MassProperties(mass, (0.0, 0.0, 0.0), tube_x(mass, g.core_radius, g.outer_radius, g.screw_length)),
            visuals=[Shape(Mesh(MESH_PREFIX + mesh_file), Pose(), "screw")],
            # the envelope swept by the blade tips: what touches the terrain
            collisions=[cylinder_along_x(g.outer_radius, g.screw_length)],
        ))
        mimic = Mimic(naming.screw_joint("front", i), -1.0, 0.0) if position == "rear" else None
        self.tree.add_joint(Joint(
            joint, "continuous", body, link, Pose((g.screw_center(position), 0.0, 0.0)), _AXES["x"],
            Limit(lim.screw_effort, lim.screw_velocity), mimic,
        ))
        self.meta_screws.append({
            "joint": joint,
            "link": link,
            "module": i,
            "position": position,
            "hand": hand,
            "lead_angle": p.lead_angle,
            "radius": g.outer_radius,
            "core_radius": g.core_radius,
            "length": g.screw_length,
            "starts": self.design.dimensions.screw_starts,
            "blade_thickness": self.design.dimensions.blade_thickness,
            "axis": "x",
            "mimic": {"joint": mimic.joint, "multiplier": mimic.multiplier, "offset": mimic.offset} if mimic else None,
            "visual_mesh": MESH_PREFIX + mesh_file,
        })
        return joint

    def _force_torque_sensor(self, i: int, parent: str, attach_x: float) -> dict[str, Any]:
        g = self.geo
        link, joint = naming.fts_link(i), naming.fts_joint(i)
        mass = self._mass("fts")
        self.tree.add_link(Link(
            link,
            MassProperties(mass, (0.0, 0.0, 0.0), solid_cylinder_x(mass, g.fts_radius, g.fts_length)),
            visuals=[cylinder_along_x(g.fts_radius, g.fts_length, 0.0, "sensor")],
        ))
        self.tree.add_joint(Joint(joint, "fixed", parent, link, Pose((attach_x + g.fts_length / 2, 0.0, 0.0))))
        entry = {"link": link, "joint": joint, "parent": parent, "module": i}
        self.meta_fts.append(entry)
        return entry

    def _cross_bar(self, parent: str, attach_x: float) -> tuple[str, float]:
        d, m = self.design.dimensions, self.design.masses
        bx, by, bz = d.cross_bar_size
        self.tree.add_link(Link(
            naming.CROSS_BAR,
            MassProperties(m.cross_bar, (bx / 2, 0.0, 0.0), solid_box(m.cross_bar, bx, by, bz)),
            visuals=[Shape(Box((bx, by, bz)), Pose((bx / 2, 0.0, 0.0)), "joint_housing")],
            collisions=[Shape(Box((bx, by, bz)), Pose((bx / 2, 0.0, 0.0)))],
        ))
        self.tree.add_joint(Joint(naming.CROSS_BAR_JOINT, "fixed", parent, naming.CROSS_BAR, Pose((attach_x, 0, 0))))
        ax, ay, az = d.avionics_size
        self.tree.add_link(Link(
            naming.AVIONICS_BOX,
            MassProperties(m.avionics, (0.0, 0.0, 0.0), solid_box(m.avionics, ax, ay, az)),
            visuals=[Shape(Box((ax, ay, az)), Pose(), "avionics")],
            collisions=[Shape(Box((ax, ay, az)), Pose())],
        ))
        # resting on top of the bar, centred over it
        self.tree.add_joint(Joint(
            naming.AVIONICS_BOX_JOINT, "fixed", naming.CROSS_BAR, naming.AVIONICS_BOX,
            Pose((bx / 2, 0.0, bz / 2 + az / 2)),
        ))
        return naming.CROSS_BAR, bx

    def _perception_head(self, parent: str, attach_x: float) -> None:
        g = self.geo
        r, length = g.body_radius, g.head_length
        self._cylinder_link(naming.HEAD, "head", r, length, "head")
        self.tree.add_joint(Joint(naming.HEAD_JOINT, "fixed", parent, naming.HEAD, Pose((attach_x, 0.0, 0.0))))
        # Sensor frames: x forward (along the robot axis), z up. IMU at the
        # head's centre, lidar on top near the front, a stereo pair on the nose.
        frames = {
            "imu": (length / 2, 0.0, 0.0),
            "lidar": (0.7 * length, 0.0, r),
            "camera_left": (length, 0.5 * r, 0.0),
            "camera_right": (length, -0.5 * r, 0.0),
        }
        for frame in naming.HEAD_SENSOR_FRAMES:
            self.tree.add_link(Link(frame))
            self.tree.add_joint(Joint(naming.sensor_joint(frame), "fixed", naming.HEAD, frame, Pose(frames[frame])))

    def _head_cap(self, parent: str, attach_x: float) -> None:
        g = self.geo
        r, length = g.body_radius, g.head_length
        mass = self._mass("head")
        barrel = length - r  # a cylinder closed by a hemisphere whose tip is at x = length
        shapes = [cylinder_along_x(r, barrel, barrel / 2), Shape(Sphere(r), Pose((barrel, 0.0, 0.0)))]
        self.tree.add_link(Link(
            naming.HEAD_CAP,
            # solid-cylinder inertia of the cap's envelope: a plausible, valid tensor
            MassProperties(mass, (length / 2, 0.0, 0.0), solid_cylinder_x(mass, r, length)),
            visuals=[Shape(s.geometry, s.pose, "head") for s in shapes],
            collisions=shapes,
        ))
        self.tree.add_joint(Joint(naming.HEAD_CAP_JOINT, "fixed", parent, naming.HEAD_CAP, Pose((attach_x, 0, 0))))

    def _metadata(self) -> dict[str, Any]:
        d, p = self.design, self.params
        head: dict[str, Any] | None = None
        if d.head == "perception" and p.head:
            head = {"kind": "perception", "link": naming.HEAD, "joint": naming.HEAD_JOINT,
                    "frames": list(naming.HEAD_SENSOR_FRAMES)}
        elif d.head == "cap" and p.head:
            head = {"kind": "cap", "link": naming.HEAD_CAP, "joint": naming.HEAD_CAP_JOINT, "frames": []}
        cross_bar = None
        if d.cross_bar:
            cross_bar = {"link": naming.CROSS_BAR, "joint": naming.CROSS_BAR_JOINT,
                         "avionics_link": naming.AVIONICS_BOX, "avionics_joint": naming.AVIONICS_BOX_JOINT,
                         "after_module": p.modules // 2 - 1}
        return _tidy({
            "design": d.name,
            "title": d.title,
            "module_count": p.modules,
            "units": "SI: m, rad, kg",
            "parameters": p.as_dict(),
            "root_link": naming.TAIL,
            "robot_axis": "+x, tail to head",
            "modules": self.meta_modules,
            "screws": self.meta_screws,
            "screw_pairs": self.meta_pairs,
            "force_torque_sensors": self.meta_fts,
            "head": head,
            "cross_bar": cross_bar,
        })


def build_robot(design: Design, params: RobotParameters) -> BuiltRobot:
    """Kinematic tree, metadata and referenced screw meshes of ``design``."""
    return _Builder(design, params).build()


def _tidy(value: Any) -> Any:
    """Round floats to 12 decimals so the YAML reads 0.15, not 0.15000000000000002."""
    if isinstance(value, float):
        return round(value, 12)
    if isinstance(value, dict):
        return {k: _tidy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_tidy(v) for v in value]
    return value


def _other_hand(hand: str) -> str:
    return "left" if hand == "right" else "right"
