"""Contact samples on the robot's body links: points on each URDF <collision> shape, fixed in its link.

A *piece* is one <collision> element of one link. Its samples cover the shape's surface with
a spacing of at most ``spacing`` (m):

    <cylinder r L>   rings around the axis (local z) at ≤ spacing apart, the two rims included
                     (the edges), max(min_around, ⌈2πr/spacing⌉) samples each; each end cap
                     a centre sample and concentric rings at ≤ spacing apart
    <capsule r L>    the cylinder's rings and a hemisphere at each end (Fibonacci points)
    <sphere r>       max(12, ⌈4πr²/spacing²⌉) Fibonacci points
    <box a b c>      a grid on each face, ≤ spacing apart, edges and corners once each

Every sample also carries its piece's *skin axis* (link frame): the axis that body
friction's anisotropy is measured along (body_contact.py) — a cylinder's or capsule's axis,
a box's longest edge, a sphere's link x (the robot's tail-to-head axis in snakesim designs).

A flat face resting on a plane touches at whole rows of samples; a curved surface only at
the samples on its lowest line, so a cylinder whose samples straddle that line sinks up to
the sag s = r(1 − cos(π/n_around)) more than its load alone (F/k) would make it: the
sampling tolerance of every curved-body test.

Links are chosen by fnmatch ``links`` patterns minus ``exclude`` patterns; with
``exclude_screws`` the design's screw links (metadata ``screws[*].link``, handled by
``screw_sdf_contact``'s thread model) are left out. Built once per robot and options:
``robot.derived(body_samples, BodySampleOptions(...))``.
"""

from __future__ import annotations

import dataclasses
import fnmatch
import math
import xml.etree.ElementTree as ET

import numpy as np

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.urdf import MultibodyModelError, rpy_matrix

SHAPES = ("cylinder", "capsule", "sphere", "box")


@dataclasses.dataclass(frozen=True)
class BodySampleOptions:
    """How the body samples are laid out (body_contact's parameters of the same names); hashable, so it keys
    :meth:`RobotModel.derived`."""

    spacing: float = 0.03
    min_around: int = 8
    links: tuple[str, ...] = ("*",)
    exclude: tuple[str, ...] = ()
    exclude_screws: bool = True
    margin: float = 0.0


@dataclasses.dataclass(frozen=True)
class BodySamples:
    """The samples of the selected links, grouped by piece (one <collision> element).

    piece_link[np] link row; piece_centre[np, 3] bounding-sphere centre (link frame) and
    piece_radius[np] its radius (+ margin); start[np + 1] sample rows of each piece;
    points[n, 3] samples, axis[n, 3] skin axis (both link frame); piece_shape[np], piece_names[np]."""

    piece_link: np.ndarray
    piece_centre: np.ndarray
    piece_radius: np.ndarray
    start: np.ndarray
    points: np.ndarray
    axis: np.ndarray
    piece_shape: tuple[str, ...]
    piece_names: tuple[str, ...]
    sag: np.ndarray                 # (np,) m, r(1 − cos(π/n_around)) of curved pieces, 0 for boxes

    @property
    def n(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_pieces(self) -> int:
        return int(self.piece_link.shape[0])


# -- one shape's samples, in its element frame (axis z for cylinders and capsules) ----------------

def _around(r: float, spacing: float, min_around: int) -> int:
    return max(min_around, math.ceil(2.0 * math.pi * r / spacing))


def _ring(r: float, n: int, z: float) -> np.ndarray:
    a = 2.0 * np.pi * np.arange(n) / n
    return np.column_stack([r * np.cos(a), r * np.sin(a), np.full(n, z)])


def _cap(r: float, z: float, spacing: float, min_around: int) -> list[np.ndarray]:
    """The centre and the inner rings of a flat end cap (the rim is the side's last ring)."""
    k = max(1, math.ceil(r / spacing))
    out = [np.array([[0.0, 0.0, z]])]
    for j in range(1, k):
        rj = r * j / k
        out.append(_ring(rj, max(3, math.ceil(_around(r, spacing, min_around) * j / k)), z))
    return out


def _fibonacci(n: int) -> np.ndarray:
    """n nearly uniform unit vectors (golden-angle spiral)."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    rho = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    a = np.pi * (3.0 - math.sqrt(5.0)) * i
    return np.column_stack([rho * np.cos(a), rho * np.sin(a), z])


def cylinder_points(r: float, length: float, spacing: float, min_around: int = 8) -> tuple[np.ndarray, float]:
    """Samples of a capped cylinder (axis z, centred) and its sag r(1 − cos(π/n_around))."""
    n_around = _around(r, spacing, min_around)
    n_rings = max(2, math.ceil(length / spacing) + 1)
    parts = [_ring(r, n_around, z) for z in np.linspace(-0.5 * length, 0.5 * length, n_rings)]
    parts += _cap(r, -0.5 * length, spacing, min_around) + _cap(r, 0.5 * length, spacing, min_around)
    return np.concatenate(parts), r * (1.0 - math.cos(math.pi / n_around))


def capsule_points(r: float, length: float, spacing: float, min_around: int = 8) -> tuple[np.ndarray, float]:
    """Samples of a capsule (cylinder of length L along z, hemispheres of radius r at ±L/2)."""
    n_around = _around(r, spacing, min_around)
    n_rings = max(2, math.ceil(length / spacing) + 1)
    parts = [_ring(r, n_around, z) for z in np.linspace(-0.5 * length, 0.5 * length, n_rings)]
    ball = r * _fibonacci(max(12, math.ceil(4.0 * math.pi * r * r / spacing ** 2)))
    parts += [ball[ball[:, 2] > 0] + [0, 0, 0.5 * length], ball[ball[:, 2] < 0] - [0, 0, 0.5 * length]]
    return np.concatenate(parts), r * (1.0 - math.cos(math.pi / n_around))


def sphere_points(r: float, spacing: float) -> tuple[np.ndarray, float]:
    n = max(12, math.ceil(4.0 * math.pi * r * r / spacing ** 2))
    # mean spacing of n points on the sphere is ~ sqrt(4π/n) r: the sag of a cap of that angular radius
    return r * _fibonacci(n), r * (1.0 - math.cos(0.5 * math.sqrt(4.0 * math.pi / n)))


def box_points(size, spacing: float) -> tuple[np.ndarray, float]:
    """Grid samples on the six faces of a box of edges ``size`` (centred), each point once."""
    h = 0.5 * np.asarray(size, dtype=float)
    axes = [np.linspace(-h[i], h[i], max(2, math.ceil(2 * h[i] / spacing) + 1)) for i in range(3)]
    pts = []
    for i in range(3):
        j, k = [a for a in range(3) if a != i]
        gj, gk = np.meshgrid(axes[j], axes[k], indexing="ij")
        for s in (-1.0, 1.0):
            p = np.zeros((gj.size, 3))
            p[:, i], p[:, j], p[:, k] = s * h[i], gj.ravel(), gk.ravel()
            pts.append(p)
    pts = np.concatenate(pts)
    return np.unique(np.round(pts, 12), axis=0), 0.0


# -- the robot's ----------------------------------------------------------------------------------

def _numbers(el, key: str, n: int, where: str) -> list[float]:
    try:
        vals = [float(v) for v in el.get(key, "").split()]
    except ValueError:
        vals = []
    if len(vals) != n or not all(math.isfinite(v) and v > 0 for v in vals):
        raise MultibodyModelError(f"{where}: <{el.tag} {key}='{el.get(key)}'> must be {n} positive number(s)")
    return vals


def _shape_samples(el, where: str, spacing: float, min_around: int):
    """(points, skin axis, bounding radius, sag) of one <geometry> child, element frame."""
    z = np.array([0.0, 0.0, 1.0])
    if el.tag == "cylinder":
        r, length = _numbers(el, "radius", 1, where)[0], _numbers(el, "length", 1, where)[0]
        pts, sag = cylinder_points(r, length, spacing, min_around)
        return pts, z, math.hypot(r, 0.5 * length), sag
    if el.tag == "capsule":
        r, length = _numbers(el, "radius", 1, where)[0], _numbers(el, "length", 1, where)[0]
        pts, sag = capsule_points(r, length, spacing, min_around)
        return pts, z, 0.5 * length + r, sag
    if el.tag == "sphere":
        r = _numbers(el, "radius", 1, where)[0]
        pts, sag = sphere_points(r, spacing)
        return pts, None, r, sag
    if el.tag == "box":
        size = _numbers(el, "size", 3, where)
        pts, sag = box_points(size, spacing)
        return pts, np.eye(3)[int(np.argmax(size))], 0.5 * float(np.linalg.norm(size)), sag
    raise MultibodyModelError(f"{where}: body contact samples {', '.join(SHAPES)}, not <{el.tag}>; exclude the "
                              f"link (body_contact 'exclude') or give it a primitive collision shape")


def selected_links(robot: RobotModel, options: BodySampleOptions) -> list[str]:
    """The links whose collision shapes get samples, in link-row order."""
    screws = {s["link"] for s in robot.metadata.get("screws") or []} if options.exclude_screws else set()
    for pat in options.links:
        if not fnmatch.filter(robot.links, pat):
            raise MultibodyModelError(f"body contact 'links' pattern '{pat}' matches no link of {robot.label}; "
                                      f"links: {', '.join(robot.links)}")
    out = []
    for ln in robot.links:
        if ln in screws or any(fnmatch.fnmatch(ln, p) for p in options.exclude):
            continue
        if any(fnmatch.fnmatch(ln, p) for p in options.links):
            out.append(ln)
    return out


def body_samples(robot: RobotModel, options: BodySampleOptions = BodySampleOptions()) -> BodySamples:
    """The body samples of ``robot``; call it as ``robot.derived(body_samples, options)``."""
    if not (math.isfinite(options.spacing) and options.spacing > 0):
        raise ValueError(f"body contact spacing = {options.spacing} m must be a positive number")
    chosen = set(selected_links(robot, options))
    rows, centres, radii, starts, pts, axes, shapes, names, sags = [], [], [], [0], [], [], [], [], []
    for el in ET.fromstring(robot.urdf).findall("link"):
        link = el.get("name")
        if link not in chosen:
            continue
        for k, col in enumerate(el.findall("collision")):
            where = f"{robot.label}: link '{link}' <collision> #{k + 1}"
            geom = col.find("geometry")
            shape = next(iter(geom), None) if geom is not None else None
            if shape is None:
                raise MultibodyModelError(f"{where}: no shape in <geometry> (valid: {', '.join(SHAPES)})")
            o = col.find("origin")
            R = rpy_matrix([float(v) for v in o.get("rpy", "0 0 0").split()]) if o is not None else np.eye(3)
            p = np.array([float(v) for v in o.get("xyz", "0 0 0").split()]) if o is not None else np.zeros(3)
            local, axis, radius, sag = _shape_samples(shape, where, options.spacing, options.min_around)
            skin = R @ axis if axis is not None else np.array([1.0, 0.0, 0.0])
            pts.append(local @ R.T + p)
            axes.append(np.broadcast_to(skin, local.shape))
            rows.append(robot.link_row[link])
            centres.append(p)
            radii.append(radius + options.margin)
            starts.append(starts[-1] + local.shape[0])
            shapes.append(shape.tag)
            names.append(f"{link}#{k + 1}")
            sags.append(sag)
    if not rows:
        raise MultibodyModelError(f"body contact: no collision shapes on the selected links of {robot.label} "
                                  f"(links {list(options.links)}, exclude {list(options.exclude)}, "
                                  f"exclude_screws {options.exclude_screws})")
    f64 = lambda a: np.ascontiguousarray(np.asarray(a, dtype=np.float64))   # noqa: E731
    return BodySamples(piece_link=np.array(rows, dtype=np.int64), piece_centre=f64(centres).reshape(-1, 3),
                       piece_radius=f64(radii), start=np.array(starts, dtype=np.int64),
                       points=f64(np.concatenate(pts)), axis=f64(np.concatenate(axes)),
                       piece_shape=tuple(shapes), piece_names=tuple(names), sag=f64(sags))
