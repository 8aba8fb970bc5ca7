"""The robot as one built thing: what every robot-facing component is handed at build time.

A scene names its robot once, on the multibody (``design``, ``modules``,
``head``, ``urdf``, ``robot``: :class:`RobotSource`). The multibody builds a
:class:`RobotModel` from it and provides it (``Provides(RobotModel)``); PID,
contact back ends, sensors, tethers, monitors, placement and the viewer
declare ``robot = Uses(RobotModel)`` and the framework hands them the same
object. So the joint order of ``tau[nj]``/``joint_q[nj]`` and the link order
of ``link_poses[nl, 7]``/``wrenches[nl, 6]`` agree by construction.

What it holds (read-only, SI units):

    links        URDF <link> names, document order (rows of link_poses, wrenches), nl
    joints       DOF joints (moving, not mimic), URDF order (tau, joint_q), nj
    tree         the parsed URDF (joints, origins, axes, inertias, limits)
    nq, nv       Pinocchio coordinates with the free-flyer tail; q_names, v_names
    groups       counter-rotating screw pairs (mimic groups)
    metadata     the design's sidecar (screws: radius, length, lead angle, hand; modules;
                 sensors): what URDF cannot say; for a bare URDF the ``NAME.snakesim.yaml``
                 beside it (snakesim.robots.sidecar: joint kinds, screws, armature), else {}
    joint_kinds  bend | twist | screw | other per DOF joint: declared by the metadata's
                 ``joints``, else from the joint's name (the designs' systematic names)
    base_dir     folder that relative mesh file names resolve against
    screw_meshes generated screw meshes not on disk (design variants)

Models derived from it by other packages (the screw layout for contact, link
meshes for the viewer, collision hulls) are built once per robot with
:meth:`RobotModel.derived`, never re-resolved from parameters.
"""

from __future__ import annotations

import fnmatch
import json
from functools import lru_cache
from pathlib import Path
from typing import Annotated, Any, Callable

import numpy as np
from pydantic import Field

from snakesim.framework import Params
from snakesim.framework.paths import assembly_path

from .urdf import MultibodyModelError, parse_urdf, read_urdf_text

JOINT_KINDS = ("bend", "twist", "screw", "other")


class RobotSource(Params):
    """Which robot: the keys a scene writes once, on the component that provides the robot."""

    urdf: Annotated[str | None, assembly_path(lambda v: not v.lstrip().startswith("<"))] = Field(
        None, description="URDF text or path (relative to the file naming it); with 'design', a user URDF of "
                          "that design (checked against its structure)")
    design: str | None = Field(None, description="snakesim.robots design, e.g. eels-1.0")
    modules: int | None = Field(None, ge=1, description="module count for a design")
    head: bool | None = Field(None, description="head on/off for a design (default: the design's)")
    robot: dict[str, Any] = Field(default_factory=dict, description="generator parameters (hand, lead_angle, ...)")

    @classmethod
    def of(cls, params) -> "RobotSource":
        """The robot-source keys of a provider's params (the multibody's, placed_multibody's)."""
        return cls(**{k: getattr(params, k) for k in cls.model_fields})

    def source_key(self) -> str:
        return json.dumps({k: getattr(self, k) for k in RobotSource.model_fields}, sort_keys=True, default=str)


def joint_kind(name: str, metadata: dict | None = None) -> str:
    """bend | twist | screw | other: the kind the robot's metadata declares for joint ``name``
    (``metadata["joints"][name]["kind"]``, from a sidecar or a registered design), else from the
    systematic names of snakesim.robots (``bend*``, ``twist*``, ``*screw*``)."""
    declared = ((metadata or {}).get("joints") or {}).get(name)
    if declared and declared.get("kind"):
        return declared["kind"]
    if name.startswith("bend"):
        return "bend"
    if name.startswith("twist"):
        return "twist"
    if "screw" in name:
        return "screw"
    return "other"


class RobotModel:
    """A built robot (see module docstring). Build with :meth:`load`, or take the multibody's."""

    def __init__(self, text: str, label: str, metadata: dict | None = None, base_dir: Path | None = None,
                 screw_meshes: dict | None = None, design: str | None = None, modules: int | None = None):
        from .model import analyse_mimic_groups, build_pin_model, coordinate_names

        self.urdf = text
        self.label = label
        self.tree = tree = parse_urdf(text, label)
        self.metadata = dict(metadata or {})
        self.base_dir = base_dir
        self.screw_meshes = dict(screw_meshes or {})
        self.design, self.modules = design, modules
        self.links = tuple(ln.name for ln in tree.links)
        self.joints = tuple(j.name for j in tree.dof_joints())
        self.nl, self.nj = len(self.links), len(self.joints)
        self.link_row = {n: i for i, n in enumerate(self.links)}
        self.dof_of = {n: i for i, n in enumerate(self.joints)}
        self.groups = analyse_mimic_groups(tree)
        ref = build_pin_model(tree, mimic=True)
        self.nq, self.nv = ref.nq, ref.nv
        q_names, v_names = coordinate_names(ref)
        self.q_names, self.v_names = tuple(q_names), tuple(v_names)
        self.joint_kinds = tuple(joint_kind(j, self.metadata) for j in self.joints)
        self._derived: dict[Any, Any] = {}

    # -- building ----------------------------------------------------------------------------
    @classmethod
    def load(cls, urdf: str | None = None, design: str | None = None, modules: int | None = None,
             head: bool | None = None, robot: dict | None = None) -> "RobotModel":
        """The model of a design (``design``, ``modules``, ``head``, generator ``robot`` params, an optional
        user ``urdf`` of that design) or of a bare URDF (text or path). Memoised per source: a model is
        immutable, so every build of the same robot in a process shares one."""
        src = RobotSource(urdf=urdf, design=design, modules=modules, head=head, robot=dict(robot or {}))
        return _load(src.source_key())

    @classmethod
    def of(cls, source: RobotSource) -> "RobotModel":
        return _load(source.source_key())

    # -- names and indices -----------------------------------------------------------------------
    def dof_index(self, joint: str) -> int:
        """Index of a DOF joint in tau / joint_q / joint_v."""
        try:
            return self.dof_of[joint]
        except KeyError:
            raise KeyError(f"'{joint}' is not a DOF joint of {self.label}; DOF joints: {', '.join(self.joints)}") from None

    def link_index(self, link: str) -> int:
        """Row of a link in link_poses / wrenches / link_velocities."""
        try:
            return self.link_row[link]
        except KeyError:
            raise KeyError(f"no link '{link}' in {self.label}; links: {', '.join(self.links)}") from None

    def mounted_link(self, link: str | None, owner: str) -> tuple[str, int]:
        """(name, row) of the link a sensor named ``owner`` sits on: ``link``, or the URDF root when None;
        an unknown name or a pattern is an error naming the owner's ``link`` key and the valid links."""
        from snakesim.components.control.joint_selection import match

        name = link if link is not None else self.tree.root
        if name not in self.link_row:
            match(self.links, name, f"{owner}: link")      # raises, listing the links
            raise ValueError(f"{owner}: link must name one link, not a pattern: '{name}'; valid: "
                             f"{', '.join(self.links)}")
        return name, self.link_row[name]

    def kind_of(self, joint: str) -> str:
        """bend | twist | screw | other of a joint: the metadata's declaration, else its name's prefix."""
        return joint_kind(joint, self.metadata)

    def continuous_mask(self) -> np.ndarray:
        """True for continuous (unbounded, wrapped) joints among the DOF joints."""
        return np.array([self.tree.joint_by_name[j].type == "continuous" for j in self.joints], dtype=bool)

    def effort_limits(self) -> np.ndarray:
        """URDF <limit effort> per DOF joint, N·m; +inf where the URDF gives none."""
        e = np.array([self.tree.joint_by_name[j].effort for j in self.joints], dtype=float)
        return np.where(e > 0, e, np.inf)

    def velocity_limits(self) -> np.ndarray:
        """URDF <limit velocity> per DOF joint, rad/s; +inf where the URDF gives none."""
        v = np.array([self.tree.joint_by_name[j].velocity for j in self.joints], dtype=float)
        return np.where(v > 0, v, np.inf)

    def position_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) URDF <limit> per DOF joint, rad; ∓inf for continuous joints (no stops)."""
        lo = np.array([self.tree.joint_by_name[j].lower for j in self.joints], dtype=float)
        hi = np.array([self.tree.joint_by_name[j].upper for j in self.joints], dtype=float)
        cont = self.continuous_mask()
        return np.where(cont, -np.inf, lo), np.where(cont, np.inf, hi)

    def cuts(self, patterns) -> tuple[list[str], list[str]]:
        """(joint names, child links) of the cuts named by ``patterns``: joint names, link names (their parent
        joint) or glob patterns of either, in the order given; an error lists the joints."""
        tree = self.tree
        joint_names = [j.name for j in tree.joints]
        names: list[str] = []
        for pat in patterns:
            if pat in tree.joint_by_name:
                hits = [pat]
            elif pat in tree.link_index:
                if pat == tree.root:
                    raise MultibodyModelError(f"cut '{pat}' is the root link; it has no parent to cut from")
                hits = [tree.parent_joint[pat].name]
            else:
                hits = fnmatch.filter(joint_names, pat) or [tree.parent_joint[ln].name for ln in
                                                            fnmatch.filter(self.links, pat) if ln != tree.root]
            if not hits:
                raise MultibodyModelError(f"cut '{pat}' matches no joint or link of {self.label}; "
                                          f"joints: {', '.join(joint_names)}")
            names += [h for h in hits if h not in names]
        return names, [tree.joint_by_name[n].child for n in names]

    # -- models built from this one ---------------------------------------------------------------
    def derived(self, build: Callable[["RobotModel"], Any], *key) -> Any:
        """``build(self, *key)`` once per (build, key) for this robot: the screw layout, link meshes, hulls.
        A pure function of the model, so sharing it is safe."""
        k = (build, *key)
        if k not in self._derived:
            self._derived[k] = build(self, *key)
        return self._derived[k]

    def __repr__(self) -> str:
        return f"<RobotModel {self.label}: {self.nl} links, {self.nj} DOF joints>"


@lru_cache(maxsize=32)
def _load(key: str) -> RobotModel:
    src = RobotSource(**json.loads(key))
    if src.design is None:
        if src.urdf is None:
            raise MultibodyModelError("no robot: give 'urdf' (text or path) or 'design' "
                                      "(a snakesim.robots design, with 'modules')")
        if src.modules is not None or src.head is not None or src.robot:
            raise MultibodyModelError("'modules', 'head' and 'robot' apply to a 'design'; with a bare 'urdf' "
                                      "leave them out")
        text, label = read_urdf_text(src.urdf)
        is_path = not src.urdf.lstrip().startswith("<")
        base = Path(src.urdf).resolve().parent if is_path else None
        metadata = _sidecar_metadata(Path(src.urdf), text, label) if is_path else None
        return RobotModel(text, label, metadata, base_dir=base)
    from snakesim.robots import load_robot

    if src.urdf is not None and src.urdf.lstrip().startswith("<"):
        raise MultibodyModelError("with 'design', 'urdf' must be a path to a user URDF of that design, not URDF text")
    try:
        desc = load_robot(src.design, modules=src.modules, head=src.head, urdf=src.urdf, **src.robot)
    except TypeError as e:
        raise MultibodyModelError(f"robot parameters {sorted(src.robot)}: {e}") from None
    except (KeyError, ValueError, FileNotFoundError) as e:
        raise MultibodyModelError(str(e.args[0]) if e.args else str(e)) from None
    count = f" ({desc.modules} modules)" if desc.modules is not None else ""
    label = f"{desc.design}{count}" + (f" from {desc.urdf_path}" if desc.source == "user" else "")
    return RobotModel(desc.urdf, label, desc.metadata, desc.base_dir, dict(desc.screw_meshes), desc.design,
                      desc.modules)


def _sidecar_metadata(path: Path, text: str, label: str) -> dict | None:
    """The metadata sidecar beside a bare URDF file (``NAME.snakesim.yaml`` for ``NAME.urdf``), validated
    and checked against the URDF's names; None without one."""
    from snakesim.robots.sidecar import RobotMetadataError, check_against_urdf, read_sidecar, sidecar_path

    side = sidecar_path(path)
    if side is None:
        return None
    try:
        metadata = read_sidecar(side)
        check_against_urdf(metadata, parse_urdf(text, label), str(side))
    except RobotMetadataError as e:
        raise MultibodyModelError(str(e)) from None
    return metadata
