"""A robot's visual geometry from its URDF: one triangle mesh per link, in the link frame.

Built from the :class:`RobotModel` the viewer is handed (its ``urdf`` text, ``base_dir`` and
``screw_meshes``), once per robot: ``robot.derived(link_meshes)``.

Each ``<link>`` (document order, the order of the multibody's ``link_poses``
rows) gets the union of its ``<visual>`` elements: cylinders (URDF: axis z,
centred), boxes, spheres and mesh files (STL/OBJ/..., ``scale`` honoured),
each placed by its ``<origin>`` (xyz, rpy = R_z R_y R_x) and coloured by its
material (``<material><color rgba>`` inline or by name). Mesh file names
resolve against the URDF's folder (``../meshes/...`` for snakesim robots);
a generated screw mesh not on disk (a design variant) is built in memory
from its :class:`~snakesim.robots.screw_mesh.ScrewGeometry`. Links without
visuals get no mesh. Units: m.
"""

from __future__ import annotations

import dataclasses
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.urdf import rpy_matrix

DEFAULT_RGBA = (0.7, 0.7, 0.72, 1.0)
CYLINDER_SECTIONS = 32


@dataclasses.dataclass(frozen=True)
class LinkMesh:
    """Triangle mesh of one link in its link frame: vertices (n, 3) m, faces (m, 3),
    normals (n, 3), colors (n, 4) uint8."""

    link: str
    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    colors: np.ndarray


def link_meshes(robot: RobotModel) -> list[LinkMesh]:
    """One :class:`LinkMesh` per URDF link of ``robot`` that has visuals, document order.

    Built once per robot: call it as ``robot.derived(link_meshes)`` (the sink and replay do), so
    every viewer of the same robot shares the meshes. A URDF given as text has no folder; its
    relative mesh names resolve against snakesim's own URDF folder."""
    from snakesim.robots.description import URDF_DIR

    base = robot.base_dir if robot.base_dir is not None else URDF_DIR
    return meshes_from_urdf(robot.urdf, Path(base), robot.screw_meshes)


def link_collision_meshes(robot: RobotModel) -> list[LinkMesh]:
    """One :class:`LinkMesh` per link with ``<collision>`` elements: the contact shapes (a screw's
    envelope cylinder instead of its bladed visual mesh), default colour. ``robot.derived`` it."""
    from snakesim.robots.description import URDF_DIR

    base = robot.base_dir if robot.base_dir is not None else URDF_DIR
    return meshes_from_urdf(robot.urdf, Path(base), robot.screw_meshes, element="collision")


def meshes_from_urdf(text: str, base_dir: Path, screws: dict | None = None, element: str = "visual") -> list[LinkMesh]:
    """Each link's ``element`` ("visual" or "collision") geometry as one mesh, link frame."""
    root = ET.fromstring(text)
    named = {m.get("name"): _rgba(m) for m in root.findall("material")}
    out = []
    for link in root.findall("link"):
        parts = []
        for vis in link.findall(element):
            mesh = _geometry(vis.find("geometry"), base_dir, screws or {}, link.get("name"))
            if mesh is None:
                continue
            R, p = _origin(vis.find("origin"))
            mat = vis.find("material")
            rgba = DEFAULT_RGBA
            if mat is not None:
                rgba = _rgba(mat) or named.get(mat.get("name")) or DEFAULT_RGBA
            v = np.asarray(mesh.vertices) @ R.T + p
            n = np.asarray(mesh.vertex_normals) @ R.T
            c = np.tile(np.round(np.asarray(rgba) * 255).astype(np.uint8), (len(v), 1))
            parts.append((v, np.asarray(mesh.faces), n, c))
        if parts:
            out.append(_merge(link.get("name"), parts))
    return out


def _merge(name, parts) -> LinkMesh:
    offsets = np.cumsum([0] + [len(v) for v, _, _, _ in parts[:-1]])
    return LinkMesh(name,
                    np.vstack([v for v, _, _, _ in parts]).astype(np.float32),
                    np.vstack([f + o for (_, f, _, _), o in zip(parts, offsets)]).astype(np.uint32),
                    np.vstack([n for _, _, n, _ in parts]).astype(np.float32),
                    np.vstack([c for _, _, _, c in parts]))


def _origin(el) -> tuple[np.ndarray, np.ndarray]:
    if el is None:
        return np.eye(3), np.zeros(3)
    xyz = np.array([float(s) for s in el.get("xyz", "0 0 0").split()])
    rpy = [float(s) for s in el.get("rpy", "0 0 0").split()]
    return rpy_matrix(rpy), xyz


def _rgba(mat_el):
    c = mat_el.find("color") if mat_el is not None else None
    if c is None or c.get("rgba") is None:
        return None
    return tuple(float(s) for s in c.get("rgba").split())


def _geometry(geom, base_dir: Path, screws: dict, link: str):
    """A trimesh for one <geometry>, smooth-shaded with creases kept; None if unusable."""
    import trimesh

    if geom is None or len(geom) == 0:
        return None
    g = geom[0]
    if g.tag == "cylinder":
        m = trimesh.creation.cylinder(radius=float(g.get("radius")), height=float(g.get("length")),
                                      sections=CYLINDER_SECTIONS)
    elif g.tag == "box":
        m = trimesh.creation.box(extents=[float(s) for s in g.get("size").split()])
    elif g.tag == "sphere":
        m = trimesh.creation.icosphere(subdivisions=2, radius=float(g.get("radius")))
    elif g.tag == "mesh":
        m = _mesh_file(g.get("filename", ""), base_dir, screws, link)
        if m is None:
            return None
        if g.get("scale"):
            m.apply_scale([float(s) for s in g.get("scale").split()])
    else:
        return None
    return m.smooth_shaded


def _mesh_file(filename: str, base_dir: Path, screws: dict, link: str):
    import trimesh

    name = filename
    for prefix in ("package://", "file://"):
        if name.startswith(prefix):
            name = name[len(prefix):]
    path = Path(name) if Path(name).is_absolute() else base_dir / name
    if path.is_file():
        from snakesim.components.multibody.urdf import MultibodyModelError, load_mesh_file

        try:
            return load_mesh_file(path, f"snakesim viz: link '{link}' <visual>", filename)
        except MultibodyModelError as e:      # the viewer shows the robot without it, saying why
            sys.stderr.write(f"{e}; shown without it\n")
            return None
    geometry = screws.get(Path(name).name)
    if geometry is not None:
        from snakesim.robots.screw_mesh import screw_triangles

        tri = np.asarray(screw_triangles(geometry)).reshape(-1, 3)
        return trimesh.Trimesh(tri, np.arange(len(tri)).reshape(-1, 3), process=True)
    sys.stderr.write(f"snakesim viz: link '{link}': visual mesh '{filename}' not found (looked in {path}); "
                     "shown without it\n")
    return None
