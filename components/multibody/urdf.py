"""URDF to a link tree: every link, every joint, mass properties, mimic relations.

This is the *unoptimised* description (each URDF link a body, each joint a
joint) that the multibody component keeps next to the Pinocchio model it
integrates: the numba kernels in :mod:`.kernels` compute every link's pose,
velocity and acceleration on it, and the inter-body wrench across any joint,
fixed ones included (force-torque sensors, paper 2.2.4), which the optimised
dynamics model -- where fixed joints and massless links are merged away --
can no longer see.

Conventions (those of URDF and Pinocchio): a joint's frame is its child
link's frame; ``<origin>`` places it in the parent link's frame with
``rpy`` = R_z(yaw) R_y(pitch) R_x(roll); revolute and continuous joints turn
about ``<axis>`` (normalised here; URDF's default +x is refused on a moving joint, which must
write its axis: a bend joint silently becoming a twist is the trap) by the joint angle. Supported
joint types: revolute, continuous, fixed (the root gets a free-flyer from the
component). Prismatic, floating and planar joints raise
:class:`MultibodyModelError` naming the joint.

Physically impossible descriptions are refused with the file, the link or joint and the value:
a non-finite number anywhere, a negative mass, inertia on a massless link, a singular inertia on a
link with mass, principal moments that break the triangle inequality (I1 + I2 >= I3), a moving
joint without ``<axis>``, ``<limit lower>`` above ``upper``, a negative effort or velocity limit.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

SUPPORTED_JOINTS = ("revolute", "continuous", "fixed")


class MultibodyModelError(ValueError):
    """A robot description the multibody component cannot use; the message
    names the source, the element and what would be valid."""


#: the mesh files a URDF's <mesh filename> may name (read with trimesh)
MESH_FORMATS = (".stl", ".obj", ".ply", ".off", ".glb", ".gltf")


def load_mesh_file(path: Path, where: str, filename: str | None = None):
    """The trimesh of a URDF ``<mesh>`` file, for every reader (collision hulls, the viewer): a file that is
    not a readable triangle mesh raises :class:`MultibodyModelError` naming ``where`` (the URDF, link and
    element), the file and the mesh formats that are valid, never trimesh's own exception."""
    import trimesh

    path = Path(path)
    name = f"'{filename}' ({path})" if filename and filename != str(path) else f"'{path}'"
    valid = f"valid: a triangle mesh file ({', '.join(MESH_FORMATS)})"
    if path.suffix.lower() not in MESH_FORMATS:
        raise MultibodyModelError(f"{where}: mesh {name} is not a mesh file (type "
                                  f"'{path.suffix or 'none'}'); {valid}")
    try:
        mesh = trimesh.load(path, force="mesh")
    except Exception as e:          # trimesh fails on a non-mesh in many ways (NotImplementedError, a missing codec...)
        # an ImportError is trimesh reaching for a text-encoding detector: the bytes are no mesh at all
        why = "" if isinstance(e, ImportError) else f": {type(e).__name__}: {e}"
        raise MultibodyModelError(f"{where}: mesh {name} cannot be read as {path.suffix.lower()[1:].upper()} "
                                  f"(a binary or corrupt file?{why}); {valid}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        # random bytes come here too when a text-encoding detector is installed (trimesh then decodes them as
        # an empty text file rather than raising): the same words either way
        raise MultibodyModelError(f"{where}: mesh {name} cannot be read as {path.suffix.lower()[1:].upper()} "
                                  f"(a binary or corrupt file? it holds no triangles); {valid}")
    return mesh


def rpy_matrix(rpy) -> np.ndarray:
    r, p, y = (float(a) for a in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return rz @ ry @ rx


@dataclass
class Joint:
    name: str
    type: str                      # revolute | continuous | fixed
    parent: str
    child: str
    rotation: np.ndarray           # origin rotation, parent link frame
    translation: np.ndarray        # origin translation, parent link frame
    axis: np.ndarray               # unit axis, joint frame (unused for fixed)
    mimic: tuple[str, float, float] | None = None   # (joint, multiplier, offset)
    effort: float = 0.0            # <limit effort>, N·m (0 when absent)
    velocity: float = 0.0          # <limit velocity>, rad/s (0 when absent)
    lower: float | None = None     # <limit lower/upper>, rad (None when absent)
    upper: float | None = None

    @property
    def moving(self) -> bool:
        return self.type != "fixed"

    @property
    def is_dof(self) -> bool:
        """A generalised coordinate of its own (moving and not a mimic)."""
        return self.moving and self.mimic is None


@dataclass
class Link:
    name: str
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))        # link frame
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))  # about the COM, link axes

    @property
    def massless(self) -> bool:
        return self.mass <= 0.0


@dataclass
class LinkTree:
    """Links and joints in document order, plus the tree relations."""

    name: str
    source: str
    links: list[Link]
    joints: list[Joint]
    root: str
    parent_joint: dict[str, Joint]            # child link -> its joint
    children: dict[str, list[Joint]]          # link -> joints to its children (document order)
    link_index: dict[str, int]
    joint_by_name: dict[str, Joint]

    # -- derived views ---------------------------------------------------------
    def topological(self) -> list[str]:
        """Links depth-first from the root, children in joint document order."""
        out, stack = [], [self.root]
        while stack:
            name = stack.pop()
            out.append(name)
            stack.extend(j.child for j in reversed(self.children.get(name, [])))
        return out

    def subtree(self, link: str) -> list[str]:
        out, stack = [], [link]
        while stack:
            name = stack.pop()
            out.append(name)
            stack.extend(j.child for j in self.children.get(name, []))
        return out

    def rigid_root(self, link: str) -> str:
        """The link heading the rigid group ``link`` belongs to (walk up fixed joints)."""
        while link in self.parent_joint and not self.parent_joint[link].moving:
            link = self.parent_joint[link].parent
        return link

    def dof_joints(self) -> list[Joint]:
        return [j for j in self.joints if j.is_dof]

    def mimics_of(self, name: str) -> list[Joint]:
        return [j for j in self.joints if j.mimic is not None and j.mimic[0] == name]

    def placement_in(self, ancestor: str, link: str) -> tuple[np.ndarray, np.ndarray]:
        """(R, p) of ``link`` in ``ancestor``'s frame through fixed joints only, at zero angles."""
        r, p = np.eye(3), np.zeros(3)
        while link != ancestor:
            j = self.parent_joint[link]
            r, p = j.rotation @ r, j.rotation @ p + j.translation
            link = j.parent
        return r, p


def _floats(text: str | None, n: int, default, where: str, what: str) -> np.ndarray:
    if text is None:
        return np.array(default, dtype=float)
    parts = text.split()
    try:
        vals = np.array([float(s) for s in parts])
    except ValueError:
        raise MultibodyModelError(f"{where}: {what}='{text}' is not {n} numbers") from None
    if vals.size != n or not np.all(np.isfinite(vals)):
        raise MultibodyModelError(f"{where}: {what}='{text}' must be {n} finite numbers")
    return vals


def _origin(el, where: str) -> tuple[np.ndarray, np.ndarray]:
    o = el.find("origin") if el is not None else None
    if o is None:
        return np.eye(3), np.zeros(3)
    xyz = _floats(o.get("xyz"), 3, (0, 0, 0), where, "origin xyz")
    rpy = _floats(o.get("rpy"), 3, (0, 0, 0), where, "origin rpy")
    return rpy_matrix(rpy), xyz


def read_urdf_text(urdf: str) -> tuple[str, str]:
    """(text, source label) from URDF text or a file path."""
    if urdf.lstrip().startswith("<"):
        return urdf, "<urdf text>"
    path = Path(urdf).expanduser()
    if not path.is_file():
        raise MultibodyModelError(f"URDF file '{urdf}' does not exist (give a path to a .urdf file or the URDF text)")
    try:
        return path.read_text(encoding="utf-8"), str(path)
    except UnicodeDecodeError as e:
        raise MultibodyModelError(f"{path}: not UTF-8 text ({e.reason} at byte {e.start}); a URDF is an XML "
                                  "text file") from None


def _check_inertia(where: str, mass: float, vals: dict, i_local: np.ndarray) -> None:
    """Refuse inertia no rigid body has (tolerance relative to the largest moment)."""
    scale = float(np.abs(i_local).max())
    shown = ", ".join(f"{k}={v:g}" for k, v in vals.items())
    if mass == 0.0:
        if scale > 0.0:
            raise MultibodyModelError(f"{where}: mass is 0 but the inertia is not ({shown}); a massless link "
                                      "has zero inertia: give its mass or remove the <inertia> values")
        return
    moments = np.linalg.eigvalsh(i_local)
    tol = 1e-9 * max(scale, 1e-300)
    if moments[0] <= tol:
        raise MultibodyModelError(
            f"{where}: mass {mass:g} kg with a singular inertia ({shown}; principal moments "
            f"{', '.join(f'{m:.6g}' for m in moments)}); a link with mass needs a positive-definite inertia "
            "(every principal moment > 0)")
    if moments[0] + moments[1] < moments[2] - tol:
        raise MultibodyModelError(
            f"{where}: inertia ({shown}) breaks the triangle inequality: principal moments "
            f"{', '.join(f'{m:.6g}' for m in moments)} need I1 + I2 >= I3 (no mass distribution has these)")


def robot_element(text: str, source: str, error: type[Exception] = MultibodyModelError) -> ET.Element:
    """The ``<robot>`` root of URDF ``text``: the one XML read for the simulator's parse and the
    structure check (snakesim.robots.structure). Malformed XML or another root element raises
    ``error`` naming ``source`` (and the line and column)."""
    try:
        robot = ET.fromstring(text)
    except ET.ParseError as e:
        line, col = e.position
        # ParseError's message ends with ": line L, column C", already in the prefix
        reason = str(e).rsplit(": line ", 1)[0]
        raise error(f"{source}:{line}:{col}: malformed XML: {reason}") from None
    if robot.tag != "robot":
        raise error(f"{source}: root element is <{robot.tag}>, a URDF needs <robot>")
    return robot


def parse_urdf(text: str, source: str = "<urdf text>") -> LinkTree:
    robot = robot_element(text, source)

    links: list[Link] = []
    seen: set[str] = set()
    for el in robot.findall("link"):
        name = el.get("name")
        if not name:
            raise MultibodyModelError(f"{source}: a <link> has no name")
        if name in seen:
            raise MultibodyModelError(f"{source}: link '{name}' is defined twice")
        seen.add(name)
        link = Link(name)
        inertial = el.find("inertial")
        where = f"{source}: link '{name}' <inertial>"
        if inertial is not None:
            m = inertial.find("mass")
            mass = float(_floats(m.get("value") if m is not None else None, 1, (0.0,), where, "mass value")[0])
            if mass < 0:
                raise MultibodyModelError(f"{where}: mass {mass:g} is negative (valid: >= 0 kg)")
            rot, xyz = _origin(inertial, where)
            it = inertial.find("inertia")
            vals = {k: 0.0 for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
            if it is not None:
                for k in vals:
                    if it.get(k) is not None:
                        vals[k] = float(_floats(it.get(k), 1, (0.0,), where, k)[0])
            i_local = np.array([[vals["ixx"], vals["ixy"], vals["ixz"]],
                                [vals["ixy"], vals["iyy"], vals["iyz"]],
                                [vals["ixz"], vals["iyz"], vals["izz"]]])
            _check_inertia(where, mass, vals, i_local)
            link.mass, link.com, link.inertia = mass, xyz, rot @ i_local @ rot.T
        links.append(link)
    if not links:
        raise MultibodyModelError(f"{source}: the URDF has no <link>")

    joints: list[Joint] = []
    jseen: set[str] = set()
    parent_joint: dict[str, Joint] = {}
    for el in robot.findall("joint"):
        name, jtype = el.get("name"), el.get("type")
        where = f"{source}: joint '{name}'"
        if not name:
            raise MultibodyModelError(f"{source}: a <joint> has no name")
        if name in jseen:
            raise MultibodyModelError(f"{where} is defined twice")
        jseen.add(name)
        if jtype not in SUPPORTED_JOINTS:
            raise MultibodyModelError(f"{where}: type '{jtype}' is not supported by the multibody component "
                                      f"(supported: {', '.join(SUPPORTED_JOINTS)})")
        p_el, c_el = el.find("parent"), el.find("child")
        parent = p_el.get("link") if p_el is not None else None
        child = c_el.get("link") if c_el is not None else None
        for role, ln in (("parent", parent), ("child", child)):
            if ln not in seen:
                raise MultibodyModelError(f"{where}: {role} link '{ln}' is not a <link> of the URDF")
        if child in parent_joint:
            raise MultibodyModelError(f"{where}: link '{child}' already has a parent joint "
                                      f"'{parent_joint[child].name}' (a URDF is a tree)")
        rot, xyz = _origin(el, where)
        axis_el = el.find("axis")
        if jtype != "fixed" and (axis_el is None or axis_el.get("xyz") is None):
            raise MultibodyModelError(f"{where}: a {jtype} joint without <axis xyz=...>; URDF would default to "
                                      "(1 0 0), a twist about the link's x axis: write the axis explicitly "
                                      "(e.g. <axis xyz=\"0 0 1\"/>)")
        axis = _floats(axis_el.get("xyz") if axis_el is not None else None, 3, (1, 0, 0), where, "axis xyz")
        if jtype != "fixed":
            n = np.linalg.norm(axis)
            if n < 1e-12:
                raise MultibodyModelError(f"{where}: axis xyz='{axis_el.get('xyz')}' is zero; a {jtype} joint "
                                          "needs a non-zero axis direction")
            axis = axis / n
        mimic = None
        mi = el.find("mimic")
        if mi is not None and jtype != "fixed":
            mult = float(_floats(mi.get("multiplier"), 1, (1.0,), where, "mimic multiplier")[0])
            off = float(_floats(mi.get("offset"), 1, (0.0,), where, "mimic offset")[0])
            mimic = (mi.get("joint"), mult, off)
        effort, velocity, lower, upper = _limits(el.find("limit"), jtype, where)
        j = Joint(name, jtype, parent, child, rot, xyz, axis, mimic, effort, velocity, lower, upper)
        joints.append(j)
        parent_joint[child] = j
    by_name = {j.name: j for j in joints}
    for j in joints:
        if j.mimic is not None:
            target = by_name.get(j.mimic[0])
            if target is None or not target.moving:
                raise MultibodyModelError(f"{source}: joint '{j.name}' mimics '{j.mimic[0]}', which is not a "
                                          "revolute or continuous joint of the URDF")
            if target.mimic is not None:
                raise MultibodyModelError(f"{source}: joint '{j.name}' mimics '{target.name}', itself a mimic "
                                          "joint; mimic the primary joint directly")

    roots = [ln.name for ln in links if ln.name not in parent_joint]
    if len(roots) != 1:
        raise MultibodyModelError(f"{source}: a URDF tree has exactly one root link; found {len(roots)}: "
                                  f"{', '.join(roots) or 'none (a cycle)'}")
    children: dict[str, list[Joint]] = {}
    for j in joints:
        children.setdefault(j.parent, []).append(j)
    tree = LinkTree(robot.get("name", "robot"), source, links, joints, roots[0], parent_joint, children,
                    {ln.name: i for i, ln in enumerate(links)}, by_name)
    if len(tree.topological()) != len(links):
        raise MultibodyModelError(f"{source}: links are not all connected to the root '{roots[0]}' (a cycle?)")
    return tree


def _limits(lim, jtype: str, where: str) -> tuple[float, float, float | None, float | None]:
    """(effort, velocity, lower, upper) of a joint's <limit>: finite numbers, effort and velocity
    >= 0, lower <= upper (0, 0, None, None where absent)."""
    if lim is None:
        return 0.0, 0.0, None, None

    def value(key, default):
        text = lim.get(key)
        return default if text is None else float(_floats(text, 1, (default,), where, f"limit {key}")[0])

    effort, velocity = value("effort", 0.0), value("velocity", 0.0)
    for key, v in (("effort", effort), ("velocity", velocity)):
        if v < 0:
            raise MultibodyModelError(f"{where}: limit {key}={v:g} is negative (valid: >= 0)")
    lower, upper = value("lower", None), value("upper", None)
    if jtype == "revolute" and lower is not None and upper is not None and lower > upper:
        raise MultibodyModelError(f"{where}: limit lower={lower:g} is above upper={upper:g} (need lower <= upper)")
    return effort, velocity, lower, upper
