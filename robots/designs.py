"""The EELS robot family (EELS-DARTS paper, section 2.1.2) as data.

Each :class:`Design` states a topology (which bodies and joints a module has)
and nominal dimensions, masses and actuator limits. The builder
(:mod:`snakesim.robots.builder`) turns a design plus parameters into a
kinematic tree. Frames and conventions shared by all designs:

* the robot axis is +x, from the tail to the head; at zero joint positions the
  robot lies straight along +x with the tail tip at the origin;
* the root link is ``tail`` (a tail cap). The simulator attaches a 6-DOF
  free-flyer there; the URDF itself has no floating joint;
* modules are numbered from the tail, ``00`` .. ``NN`` (two digits, so at most
  100 modules). Module ``i`` hangs from its predecessor (the tail for ``i=0``)
  by its bend joint ``bend_i`` -- so N modules have N bend joints, which is how
  the paper counts "3 revolute joints per module plus 6 free DOFs" = 36 DOF for
  10 modules of EELS 1.0 front-only;
* bend joints turn about the module's y axis (pitch), or alternately y and z
  (pitch, yaw, pitch, ...; even indices pitch) for designs without twist
  joints, so the body can still take 3-D shapes; twist joints and screws turn
  about the module's x axis;
* screws: ``screw_front_i`` / ``screw_rear_i`` (continuous joints) carrying
  links ``screw_front_link_i`` / ``screw_rear_link_i``. The rear screw of a
  counter-rotating pair has ``<mimic joint="screw_front_i" multiplier="-1">``
  and the opposite thread hand: a right-handed screw spinning at +w about +x
  advances along +x like a bolt in a nut, and a left-handed screw spinning at
  -w advances along +x too, so the pair's thrusts add while their reaction
  torques about the axis cancel.

Topologies (``knuckle_i`` is the short bend-joint housing between the bend and
the twist joint):

``eels-concept``
    tail -bend_i(y/z alternating)-> module_i; module_i carries screw_front_i
    and screw_rear_i (counter-rotating pair). No twist joints. Capped head:
    ``head_cap`` fixed to the last module (``head_cap_joint``), optional.
    Joints per module: bend, 2 screws (1 mimics the other).
``eels-1.0`` (alternating, 10 modules)
    tail -bend_i(y)-> knuckle_i -twist_i(x)-> module_i; module_i carries the
    counter-rotating pair screw_front_i / screw_rear_i. Optional perception
    head: ``head`` fixed to the last module (``head_joint``) with massless
    frames ``imu``, ``lidar``, ``camera_left``, ``camera_right`` (fixed joints
    ``<frame>_joint``). Joints per module: bend, twist, 2 screws (1 mimic).
``eels-1.0-front``
    as ``eels-1.0`` without the rear screw: module_i carries screw_front_i
    only. Joints per module: bend, twist, 1 screw.
``eels-1.5``
    as ``eels-1.0-front`` (bend, twist, one screw per module), smaller, plus
    a ``cross_bar`` fixed after module ``N//2 - 1`` (after the tail when
    N = 1; ``cross_bar_joint``) carrying an ``avionics_box``
    (``avionics_box_joint``), and a 6-axis force-torque sensor in front of every
    module but the first: link ``fts_i`` fixed to the preceding body (module
    or cross bar) by ``fts_joint_i`` located at the sensing frame; ``bend_i``
    then hangs from ``fts_i`` so the whole load transmitted to module i and
    beyond passes through the sensor (paper 2.2.4).
``mini-eels-1.0``
    tail -bend_i(y/z alternating)-> module_i. Bend joints only, no screws,
    no head.

Twist joints never separate the two screws of a pair: in every design with a
pair (``eels-concept``, ``eels-1.0``) both screws hang from the same rigid
body ``module_i``, and the twist joint (where there is one) sits between the
bend knuckle and that body, *behind* both screws. This matches the hardware,
whose counter-rotation comes from a transmission inside one module, and it
is what makes embedding the pair as one DOF (paper 2.1.3) exact.

DOF of the free-flyer model (nv; Pinocchio nq is larger because a free-flyer
has nq=7 and each continuous joint nq=2):

================  ==================  ===================
design            mimic ignored       mimic honoured
================  ==================  ===================
eels-concept      6 + 3 N             6 + 2 N
eels-1.0          6 + 4 N             6 + 3 N
eels-1.0-front    6 + 3 N             6 + 3 N
eels-1.5          6 + 3 N             6 + 3 N
mini-eels-1.0     6 + N               6 + N
================  ==================  ===================
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field, replace
from typing import Literal, Mapping

ScrewLayout = Literal["pair", "front", "none"]

#: A geared actuator's reflected inertia J_m·N² and peak torque T_m·N scale together:
#: J/T = (J_m/T_m)·N ≈ 2e-3 s² for harmonic-drive bend/twist actuators (BLDC J_m/T_m ~ 2e-5 s²,
#: N ~ 100) and hobby servos alike, less for the lower-ratio screw drives. kg·m² per N·m of effort.
GEARED_ARMATURE_PER_EFFORT = {"bend": 2e-3, "twist": 2e-3, "screw": 7e-4, "other": 1e-3}
BendAxes = Literal["pitch", "alternating"]
HeadKind = Literal["perception", "cap", "none"]


@dataclass(frozen=True)
class Dimensions:
    """Nominal geometry (m, rad). ``outer_radius`` is the screw envelope
    radius for screw designs and the body radius for screwless ones; radial
    sizes of bodies derive from it so a ``screw_radius`` change keeps the
    robot consistent."""

    module_length: float  # bend axis to next bend axis (m)
    outer_radius: float  # screw envelope radius, or body radius without screws (m)
    core_ratio: float  # screw core (drum) radius / outer radius; also the body radius ratio
    tail_length: float
    knuckle_length: float = 0.0  # bend axis to twist axis; 0 without twist joints
    screw_gap: float = 0.01  # axial clearance at each end of a screw (m)
    blade_thickness: float = 0.004  # axial thickness of a screw blade (m), visual only
    screw_starts: int = 2  # number of helical blades (thread starts) per screw
    lead_angle: float = 0.35  # thread angle from the plane normal to the axis, at the outer radius (rad)
    hand: Literal["right", "left"] = "right"  # thread hand of the front screws
    head_length: float = 0.0
    fts_length: float = 0.0  # axial length of a force-torque sensor (m)
    cross_bar_size: tuple[float, float, float] = (0.0, 0.0, 0.0)  # x, y, z (m)
    avionics_size: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Masses:
    """Nominal masses (kg) at the nominal dimensions; the builder scales each
    body's mass with its envelope volume when dimensions change."""

    tail: float
    module_body: float
    knuckle: float = 0.0
    screw: float = 0.0
    head: float = 0.0
    fts: float = 0.0
    cross_bar: float = 0.0
    avionics: float = 0.0


@dataclass(frozen=True)
class ActuatorLimits:
    """Joint limits: range (rad, symmetric), effort (N·m), velocity (rad/s)."""

    bend_range: float
    bend_effort: float
    bend_velocity: float
    twist_range: float = 0.0
    twist_effort: float = 0.0
    twist_velocity: float = 0.0
    screw_effort: float = 0.0
    screw_velocity: float = 0.0


@dataclass(frozen=True)
class Design:
    """One member of the EELS family: topology flags plus nominal numbers."""

    name: str
    title: str
    default_modules: int
    screws: ScrewLayout
    twist: bool
    bend_axes: BendAxes
    head: HeadKind
    cross_bar: bool
    force_torque_sensors: bool
    dimensions: Dimensions
    masses: Masses
    limits: ActuatorLimits
    #: reflected rotor inertia per joint kind (bend, twist, screw, other), kg·m² per N·m of the joint's
    #: effort limit: a URDF has no armature, so the design says what its geared joints carry. The
    #: multibody uses it unless the scene sets ``armature`` / ``armature_per_effort``; `snakesim check`
    #: prints the values and where each came from.
    armature_per_effort: Mapping[str, float] = field(default_factory=lambda: dict(GEARED_ARMATURE_PER_EFFORT))

    @property
    def has_screws(self) -> bool:
        return self.screws != "none"

    @property
    def has_head_option(self) -> bool:
        return self.head != "none"

    def joints_per_module(self) -> int:
        """Moving joints per module: bend + twist + screws (mimic joints included)."""
        return 1 + int(self.twist) + {"pair": 2, "front": 1, "none": 0}[self.screws]

    def mimic_joints_per_module(self) -> int:
        return 1 if self.screws == "pair" else 0


# EELS 1.0 sizing: ~4.4 m and ~100 kg for 10 modules, screws of 0.09 m outer
# radius. 10 x (1.5 knuckle + 4.0 body + 2 x 2.0 screws) + 1.5 tail + 3.5 head = 100 kg.
_EELS_1_0 = Design(
    name="eels-1.0",
    title="EELS 1.0, alternating (two counter-rotating screws per module, optional perception head)",
    default_modules=10,
    screws="pair", twist=True, bend_axes="pitch", head="perception",
    cross_bar=False, force_torque_sensors=False,
    dimensions=Dimensions(
        module_length=0.40, outer_radius=0.09, core_ratio=0.75, tail_length=0.10,
        knuckle_length=0.06, screw_starts=3, lead_angle=0.35, head_length=0.25,
    ),
    masses=Masses(tail=1.5, module_body=4.0, knuckle=1.5, screw=2.0, head=3.5),
    limits=ActuatorLimits(
        bend_range=math.pi / 4, bend_effort=120.0, bend_velocity=1.0,
        twist_range=math.pi / 2, twist_effort=60.0, twist_velocity=1.0,
        screw_effort=30.0, screw_velocity=10.0,
    ),
)

DESIGNS: Mapping[str, Design] = {
    d.name: d
    for d in (
        Design(
            name="eels-concept",
            title="EELS early design concept (two counter-rotating screws per module, capped head)",
            default_modules=8,
            screws="pair", twist=False, bend_axes="alternating", head="cap",
            cross_bar=False, force_torque_sensors=False,
            dimensions=Dimensions(
                module_length=0.45, outer_radius=0.09, core_ratio=0.75, tail_length=0.10,
                screw_starts=3, lead_angle=0.35, head_length=0.12,
            ),
            masses=Masses(tail=1.5, module_body=5.0, screw=2.0, head=1.0),
            limits=ActuatorLimits(bend_range=math.pi / 4, bend_effort=120.0, bend_velocity=1.0,
                                  screw_effort=30.0, screw_velocity=10.0),
        ),
        _EELS_1_0,
        # the same hardware with the rear screws removed
        replace(_EELS_1_0, name="eels-1.0-front", screws="front",
                title="EELS 1.0, front only (one screw per module, optional perception head)"),
        Design(
            name="eels-1.5",
            title="EELS 1.5 (subsurface; cross bar with avionics box, force-torque sensors between modules)",
            default_modules=4,
            screws="front", twist=True, bend_axes="pitch", head="none",
            cross_bar=True, force_torque_sensors=True,
            # 0.08 tail + 4 x 0.35 modules + 0.20 cross bar = 1.68 m
            dimensions=Dimensions(
                module_length=0.35, outer_radius=0.07, core_ratio=0.75, tail_length=0.08,
                knuckle_length=0.05, screw_starts=2, lead_angle=0.35, fts_length=0.03,
                cross_bar_size=(0.20, 0.40, 0.04), avionics_size=(0.18, 0.14, 0.10),
            ),
            masses=Masses(tail=1.0, module_body=3.0, knuckle=1.0, screw=1.5, fts=0.3,
                          cross_bar=2.5, avionics=3.0),
            limits=ActuatorLimits(
                bend_range=math.pi / 4, bend_effort=80.0, bend_velocity=1.0,
                twist_range=math.pi / 2, twist_effort=40.0, twist_velocity=1.0,
                screw_effort=20.0, screw_velocity=10.0,
            ),
        ),
        Design(
            name="mini-eels-1.0",
            title="Mini EELS 1.0 (bend joints only, no screws)",
            default_modules=10,
            screws="none", twist=False, bend_axes="alternating", head="none",
            cross_bar=False, force_torque_sensors=False,
            # hobby-servo modules: 0.06 tail + 10 x 0.09 = 0.96 m, ~3 kg
            dimensions=Dimensions(module_length=0.09, outer_radius=0.028, core_ratio=1.0, tail_length=0.06),
            masses=Masses(tail=0.15, module_body=0.28),
            limits=ActuatorLimits(bend_range=math.pi / 2, bend_effort=3.0, bend_velocity=5.0),
        ),
    )
}

MIN_MODULES = 1
MAX_MODULES = 100  # names carry two-digit indices 00..99


def get_design(name: str) -> Design:
    """The design called ``name``; a ``KeyError`` listing the valid names and
    the closest matches otherwise."""
    try:
        return DESIGNS[name]
    except (KeyError, TypeError):
        pass
    query = str(name).strip().lower()
    close = difflib.get_close_matches(query, list(DESIGNS), n=3, cutoff=0.5)
    # a fragment such as "mini" or "1.5" is too short for difflib's ratio
    close += [d for d in DESIGNS if query and query in d and d not in close]
    hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    raise UnknownDesignError(
        f"unknown robot design {name!r}.{hint} Valid designs: {', '.join(DESIGNS)}"
    )


class UnknownDesignError(KeyError, ValueError):
    """A design name that is not in :data:`DESIGNS`. Subclasses both KeyError
    (it is a failed registry look-up) and ValueError (a bad argument value)."""

    def __str__(self) -> str:  # KeyError would repr() the message
        return str(self.args[0]) if self.args else ""
