"""Visual meshes of EELS screws: a core drum with helical blades, as binary STL.

Frame: the screw link frame, origin at the screw's centre on its axis, x along
the spin axis. Units: m.

Helix convention. A blade's centre line at radius r is

    (x, y, z) = (x0 + s * lead * theta / (2 pi), r cos(theta), r sin(theta))

with s = +1 for a right-handed thread and s = -1 for a left-handed one (for
s = +1, turning by +theta about +x advances +x: the right-hand rule). The
lead is the axial advance of one blade per turn, from the lead angle lambda
measured at the outer radius: tan(lambda) = lead / (2 pi r_outer). A screw
with several starts has that many blades, offset by 2 pi / starts.

Each blade is a rectangle (radial: core to outer radius; axial: the blade
thickness) swept along the helix, closed by end caps, so the mesh is a set of
closed, consistently outward-wound solids.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

# Angular resolution: enough for a smooth look, while a screw stays at a few
# thousand triangles at most.
_SEGMENTS_PER_TURN = 48
_CORE_SEGMENTS = 48

_STL_DTYPE = np.dtype([("normal", "<f4", (3,)), ("vertices", "<f4", (3, 3)), ("attr", "<u2")])


@dataclass(frozen=True)
class ScrewGeometry:
    """Everything the visual mesh depends on (m, rad)."""

    hand: str  # "right" or "left"
    lead_angle: float
    outer_radius: float
    core_radius: float
    length: float
    starts: int
    blade_thickness: float

    @property
    def lead(self) -> float:
        """Axial advance of one blade per turn (m)."""
        return 2.0 * math.pi * self.outer_radius * math.tan(self.lead_angle)

    @property
    def handedness(self) -> int:
        """+1 for a right-handed thread, -1 for a left-handed one."""
        return 1 if self.hand == "right" else -1

    def quantized(self) -> "ScrewGeometry":
        """Values rounded to the resolution of :meth:`filename` (0.1 mm,
        0.1 mrad), so one file name always means one mesh."""
        return ScrewGeometry(
            self.hand, round(self.lead_angle, 4), round(self.outer_radius, 4), round(self.core_radius, 4),
            round(self.length, 4), self.starts, round(self.blade_thickness, 4),
        )

    def filename(self) -> str:
        """A file name that encodes the geometry, e.g.
        ``screw_right_lead0.35_r0.09_core0.0675_len0.15_starts3_t0.004.stl``."""
        q = self.quantized()
        return (
            f"screw_{q.hand}_lead{q.lead_angle:g}_r{q.outer_radius:g}_core{q.core_radius:g}"
            f"_len{q.length:g}_starts{q.starts}_t{q.blade_thickness:g}.stl"
        )


def screw_triangles(geometry: ScrewGeometry) -> np.ndarray:
    """Triangles (T, 3, 3) of the core drum and all blades, outward wound."""
    g = geometry
    if g.hand not in ("right", "left"):
        raise ValueError(f"hand must be 'right' or 'left', got {g.hand!r}")
    if not 0.0 < g.core_radius < g.outer_radius:
        raise ValueError(f"core radius {g.core_radius} m must be in (0, outer radius {g.outer_radius} m)")
    if not 0.0 < g.blade_thickness < g.length:
        raise ValueError(f"blade thickness {g.blade_thickness} m must be in (0, screw length {g.length} m)")
    solids = [_core(g)] + [_blade(g, start) for start in range(g.starts)]
    return np.concatenate(solids)


def blade_volume(geometry: ScrewGeometry) -> float:
    """Exact volume (m³) of all blades: the swept rectangle occupies, in
    cylindrical coordinates, t * (r_o² - r_i²) / 2 per radian of sweep."""
    g = geometry
    sweep = 2.0 * math.pi * (g.length - g.blade_thickness) / g.lead
    return g.starts * g.blade_thickness * (g.outer_radius**2 - g.core_radius**2) / 2.0 * sweep


def binary_stl_bytes(triangles: np.ndarray, header: str = "") -> bytes:
    """Triangles (T, 3, 3) as a binary STL with per-facet normals."""
    tri = np.asarray(triangles, dtype=np.float64)
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norms = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, norms, out=np.zeros_like(normals), where=norms > 0)
    records = np.zeros(len(tri), dtype=_STL_DTYPE)
    records["normal"] = normals
    records["vertices"] = tri
    head = header.encode("ascii", "replace")[:80].ljust(80, b" ")
    # STL headers must not start with "solid", or readers take the file for ASCII STL.
    if head.startswith(b"solid"):
        head = b"x" + head[1:]
    return head + np.uint32(len(tri)).tobytes() + records.tobytes()


def write_binary_stl(path: Path, triangles: np.ndarray, header: str = "") -> None:
    """Write triangles (T, 3, 3) as a binary STL with per-facet normals."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as f:
        f.write(binary_stl_bytes(triangles, header))


def screw_mesh_bytes(geometry: "ScrewGeometry") -> tuple[str, bytes]:
    """(file name, binary STL) of the screw mesh, as :func:`write_screw_mesh` writes it."""
    q = geometry.quantized()
    return q.filename(), binary_stl_bytes(screw_triangles(q), header=f"snakesim EELS screw {q.filename()}")


def write_screw_mesh(directory: Path, geometry: ScrewGeometry) -> Path:
    """Write the screw mesh into ``directory`` under :meth:`ScrewGeometry.filename`."""
    q = geometry.quantized()
    path = Path(directory) / q.filename()
    write_binary_stl(path, screw_triangles(q), header=f"snakesim EELS screw {q.filename()}")
    return path


def _core(g: ScrewGeometry) -> np.ndarray:
    phi = np.linspace(0.0, 2.0 * np.pi, _CORE_SEGMENTS, endpoint=False)
    circle = np.stack([np.zeros_like(phi), g.core_radius * np.cos(phi), g.core_radius * np.sin(phi)], axis=1)
    rings = np.stack([circle + [-g.length / 2, 0, 0], circle + [g.length / 2, 0, 0]])
    return _sweep_closed(rings)


def _blade(g: ScrewGeometry, start: int) -> np.ndarray:
    travel = g.length - g.blade_thickness  # axial travel of the blade's mid-plane
    turns = travel / g.lead
    samples = max(4, math.ceil(turns * _SEGMENTS_PER_TURN)) + 1
    u = np.linspace(0.0, 1.0, samples)
    x_mid = -travel / 2 + u * travel
    theta = 2.0 * np.pi * start / g.starts + g.handedness * 2.0 * np.pi * turns * u
    # Cross-section corners (radius, axial offset), walked around the rectangle.
    section = [(g.core_radius, -g.blade_thickness / 2), (g.outer_radius, -g.blade_thickness / 2),
               (g.outer_radius, g.blade_thickness / 2), (g.core_radius, g.blade_thickness / 2)]
    rings = np.stack(
        [np.stack([x_mid + dx, r * np.cos(theta), r * np.sin(theta)], axis=1) for r, dx in section], axis=1
    )
    return _sweep_closed(rings)


def _sweep_closed(rings: np.ndarray) -> np.ndarray:
    """Close a sweep of convex polygons (K rings of M points) into a solid.

    Side quads run ring k -> k+1; the caps traverse their edges opposite to
    the adjacent side quads, which makes the whole surface consistently
    wound. The winding is then made outward by the sign of the enclosed
    volume.
    """
    k, m = rings.shape[:2]
    j = np.arange(m)
    jn = (j + 1) % m
    a, b = rings[:-1][:, j], rings[:-1][:, jn]
    c, d = rings[1:][:, jn], rings[1:][:, j]
    sides = np.concatenate([np.stack([a, b, c], axis=2), np.stack([a, c, d], axis=2)], axis=1).reshape(-1, 3, 3)
    fan = np.arange(1, m - 1)
    first, last = rings[0], rings[-1]
    start_cap = np.stack([np.repeat(first[:1], m - 2, 0), first[fan + 1], first[fan]], axis=1)
    end_cap = np.stack([np.repeat(last[:1], m - 2, 0), last[fan], last[fan + 1]], axis=1)
    tri = np.concatenate([sides, start_cap, end_cap])
    if _signed_volume(tri) < 0:
        tri = tri[:, ::-1]
    return tri


def _signed_volume(tri: np.ndarray) -> float:
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0)
