"""The robot's collision pieces for coal, from the URDF's <collision> elements.

A *piece* is one convex coal shape fixed in one link frame: pose (R, p) in the link
frame, a bounding sphere (centre in the link frame, radius) for the broad phase. Per
URDF geometry:

    <cylinder r L>  coal.Cylinder (coal's axis is local z, as URDF's), cut into
                    ``cylinder_slices`` equal cylinders along the axis: one terrain contact
                    per slice, so a screw envelope lying on uneven ground gets that many
                    contact points (the SDF back end's sample rings play the same role)
    <box>           coal.Box;  <sphere> coal.Sphere
    <mesh>          ``mesh_hulls`` slab hulls along the mesh's longest extent (decompose.py)

Screw links (named in the design's metadata) carry the envelope cylinder in the URDF.
With ``screw_geometry="blades"`` it is replaced by the convex decomposition of the true
helical blade mesh into ``blade_hulls`` slab hulls (paper fig. 4), in the screw link
frame: those pieces turn with the screw, so contacts depend on the spin angle.

Body-to-body filter. Every link gets a position along the robot: module i's bodies
(metadata ``modules[i].bodies``) i, the tail −1, the head N, the cross bar and its
avionics box (after module k) k + ½; links without collision geometry do not matter.
Two pieces are tested against each other when their links' positions differ by at least
``min_module_gap`` (2: non-adjacent modules; the module body cylinder lies inside its own
screw envelopes, and neighbours touch at the bend housings), and never when one link is
the other's parent. A bare URDF (no design metadata) uses the number of moving joints on
the tree path between the two links instead, ≥ ``min_module_gap`` + 1.

Built from the multibody's :class:`RobotModel` (its URDF text and parsed tree, metadata,
``base_dir`` for relative mesh paths, ``screw_meshes`` for generated screw meshes not on
disk) once per robot and geometry options: ``robot.derived(robot_geometry, options)``.
"""

from __future__ import annotations

import dataclasses
import functools
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.urdf import MultibodyModelError, load_mesh_file, rpy_matrix

from .decompose import screw_mesh, slab_hulls, to_coal_convex


@dataclasses.dataclass
class RobotGeometry:
    link_names: list[str]
    geoms: list                     # coal shapes, one per piece
    piece_link: np.ndarray          # (np,) link row of each piece
    piece_R: np.ndarray             # (np,3,3) piece pose in its link frame
    piece_p: np.ndarray             # (np,3)
    sphere_c: np.ndarray            # (np,3) bounding-sphere centre, link frame
    sphere_r: np.ndarray            # (np,) m
    screw_hand: np.ndarray          # (nl,) +1 right, −1 left, 0 not a screw
    screw_lead: np.ndarray          # (nl,) lead angle, rad
    pair_a: np.ndarray              # (npairs,) piece indices of body-to-body candidate pairs
    pair_b: np.ndarray

    @property
    def n_pieces(self) -> int:
        return len(self.geoms)


def _cylinder_pieces(radius, length, slices):
    import coal

    h = length / slices
    z = (np.arange(slices) + 0.5) * h - 0.5 * length
    return [(coal.Cylinder(radius, h), np.array([0.0, 0.0, zi]), np.zeros(3), float(np.hypot(radius, h / 2)))
            for zi in z]


def _hull_pieces(hulls):
    out = []
    for h in hulls:
        v = np.asarray(h.vertices)
        c = 0.5 * (v.min(axis=0) + v.max(axis=0))
        out.append((to_coal_convex(v, np.asarray(h.faces)), np.zeros(3), c, float(np.linalg.norm(v - c, axis=1).max())))
    return out


@functools.lru_cache(maxsize=16)
def _blade_hulls(geometry, n):
    return slab_hulls(screw_mesh(geometry), n, axis=(1.0, 0.0, 0.0))


def _mesh(el, where, base_dir, screw_meshes):
    """trimesh of a <mesh> collision element: the file (relative to base_dir), else a generated screw mesh."""
    fname = el.get("filename", "")
    name = fname
    for prefix in ("package://", "file://"):
        name = name.removeprefix(prefix)
    path = Path(name)
    path = path if path.is_absolute() else base_dir / path
    if path.is_file():
        return load_mesh_file(path, where, fname)
    geometry = screw_meshes.get(Path(name).name)
    if geometry is not None:
        return screw_mesh(geometry)
    raise MultibodyModelError(f"{where}: collision mesh '{fname}' not found (looked at {path})")


def _geometry_pieces(geom_el, where, base_dir, screw_meshes, cylinder_slices, mesh_hulls):
    """[(coal shape, offset in the element frame, sphere centre in the element frame, radius)]."""
    import coal

    def num(el, key):
        try:
            vals = [float(v) for v in el.get(key, "").split()]
        except ValueError:
            vals = []
        if not vals or not all(np.isfinite(vals)) or min(vals) <= 0:
            raise MultibodyModelError(f"{where}: <{el.tag} {key}='{el.get(key)}'> must be positive numbers")
        return vals

    el = next(iter(geom_el), None)
    if el is None:
        raise MultibodyModelError(f"{where}: <geometry> is empty (valid: cylinder, box, sphere, mesh)")
    if el.tag == "cylinder":
        return _cylinder_pieces(num(el, "radius")[0], num(el, "length")[0], cylinder_slices)
    if el.tag == "box":
        size = np.array(num(el, "size"))
        if size.size != 3:
            raise MultibodyModelError(f"{where}: <box size> needs 3 numbers, got '{el.get('size')}'")
        return [(coal.Box(*size), np.zeros(3), np.zeros(3), float(0.5 * np.linalg.norm(size)))]
    if el.tag == "sphere":
        r = num(el, "radius")[0]
        return [(coal.Sphere(r), np.zeros(3), np.zeros(3), r)]
    if el.tag == "mesh":
        mesh = _mesh(el, where, base_dir, screw_meshes)
        if el.get("scale"):
            mesh.apply_scale(num(el, "scale"))
        ext = mesh.bounds[1] - mesh.bounds[0]
        axis = np.eye(3)[int(np.argmax(ext))]
        return _hull_pieces(slab_hulls(mesh, mesh_hulls, axis))
    raise MultibodyModelError(f"{where}: unsupported collision geometry <{el.tag}>; valid: cylinder, box, sphere, mesh")


def _positions(tree, metadata):
    """Position of each link along the robot (see the module docstring), or None without metadata."""
    if not metadata:
        return None
    pos = {}
    for m in metadata.get("modules", []):
        for b in m["bodies"]:
            pos[b] = float(m["index"])
    pos[metadata.get("root_link", "tail")] = -1.0
    n = float(metadata.get("module_count", len(metadata.get("modules", []))))
    if metadata.get("head"):
        pos[metadata["head"]["link"]] = n
    cb = metadata.get("cross_bar")
    if cb:
        pos[cb["link"]] = pos[cb["avionics_link"]] = cb["after_module"] + 0.5
    out = {}
    for ln in tree.topological():        # parents first: inherit the parent's position
        out[ln] = pos.get(ln, out.get(tree.parent_joint[ln].parent) if ln in tree.parent_joint else -1.0)
    return out


def _joint_distance(tree, a, b):
    """Moving joints on the tree path between links a and b."""
    def up(ln):
        path = [ln]
        while ln in tree.parent_joint:
            ln = tree.parent_joint[ln].parent
            path.append(ln)
        return path
    pa, pb = up(a), up(b)
    common = next(x for x in pa if x in set(pb))
    moving = 0
    for path in (pa, pb):
        for ln in path[:path.index(common)]:
            moving += tree.parent_joint[ln].moving
    return moving


@dataclasses.dataclass(frozen=True)
class GeometryOptions:
    """How the collision pieces are cut (hull_contact's parameters of the same names); hashable, so it keys
    :meth:`RobotModel.derived`."""

    cylinder_slices: int = 3
    screw_geometry: str = "envelope"
    blade_hulls: int = 8
    mesh_hulls: int = 4
    min_module_gap: int = 2


def robot_geometry(robot: RobotModel, options: GeometryOptions = GeometryOptions()) -> RobotGeometry:
    """Collision pieces of every link of ``robot`` (its link rows); call it as
    ``robot.derived(robot_geometry, options)``: built once per robot and options, read-only afterwards."""
    base_dir = robot.base_dir if robot.base_dir is not None else Path(".")
    return build_robot_geometry(robot, base_dir, **dataclasses.asdict(options))


def build_robot_geometry(robot: RobotModel, base_dir: Path, *, cylinder_slices: int = 3,
                         screw_geometry: str = "envelope", blade_hulls: int = 8, mesh_hulls: int = 4,
                         min_module_gap: int = 2) -> RobotGeometry:
    """Collision pieces of every link (URDF document order = the multibody's link rows)."""
    from snakesim.robots.screw_mesh import ScrewGeometry

    if screw_geometry not in ("envelope", "blades"):
        raise ValueError(f"screw_geometry '{screw_geometry}' is not one of envelope, blades")
    tree, metadata, source = robot.tree, robot.metadata, robot.label
    names = list(robot.links)
    row = robot.link_row
    screws = {s["link"]: s for s in metadata.get("screws") or []}
    if screw_geometry == "blades" and not screws:
        raise ValueError(f"screw_geometry 'blades' needs a design with screws (got {source}, which has none)")
    hand, lead = np.zeros(len(names)), np.zeros(len(names))
    for link, s in screws.items():
        hand[row[link]] = 1.0 if s["hand"] == "right" else -1.0
        lead[row[link]] = s["lead_angle"]

    geoms, link_of, Rs, ps, cs, rs = [], [], [], [], [], []

    def add(link, pieces, R_el, p_el):
        for g, off, c, r in pieces:
            geoms.append(g)
            link_of.append(row[link])
            Rs.append(R_el)
            ps.append(R_el @ off + p_el)
            cs.append(R_el @ (off + c) + p_el)
            rs.append(r)

    for el in ET.fromstring(robot.urdf).findall("link"):
        link = el.get("name")
        if screw_geometry == "blades" and link in screws:
            s = screws[link]
            g = ScrewGeometry(s["hand"], s["lead_angle"], s["radius"], s["core_radius"], s["length"], s["starts"],
                              s["blade_thickness"]).quantized()
            add(link, _hull_pieces(_blade_hulls(g, blade_hulls)), np.eye(3), np.zeros(3))
            continue
        for k, col in enumerate(el.findall("collision")):
            where = f"{source}: link '{link}' <collision> #{k + 1}"
            geom = col.find("geometry")
            if geom is None:
                raise MultibodyModelError(f"{where}: no <geometry>")
            o = col.find("origin")
            R_el = rpy_matrix([float(v) for v in o.get("rpy", "0 0 0").split()]) if o is not None else np.eye(3)
            p_el = np.array([float(v) for v in o.get("xyz", "0 0 0").split()]) if o is not None else np.zeros(3)
            add(link, _geometry_pieces(geom, where, base_dir, robot.screw_meshes, cylinder_slices, mesh_hulls),
                R_el, p_el)

    link_of = np.array(link_of, dtype=np.int64)
    pos = _positions(tree, metadata)
    parent = {row[c]: row[j.parent] for c, j in tree.parent_joint.items()}
    collide = np.zeros((len(names), len(names)), dtype=bool)
    for a in set(link_of.tolist()):
        for b in set(link_of.tolist()):
            if a >= b or parent.get(a) == b or parent.get(b) == a:
                continue
            if pos is not None:
                collide[a, b] = abs(pos[names[a]] - pos[names[b]]) >= min_module_gap
            else:
                collide[a, b] = _joint_distance(tree, names[a], names[b]) >= min_module_gap + 1
    ia, ib = np.triu_indices(len(geoms), k=1)
    la, lb = link_of[ia], link_of[ib]
    keep = collide[np.minimum(la, lb), np.maximum(la, lb)]
    return RobotGeometry(
        names, geoms, link_of, np.array(Rs).reshape(-1, 3, 3), np.array(ps).reshape(-1, 3),
        np.array(cs).reshape(-1, 3), np.array(rs), hand, lead, ia[keep], ib[keep])
