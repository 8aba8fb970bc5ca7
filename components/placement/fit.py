"""Shape guess -> initial joint angles and base pose of a snake robot (paper 2.2.6, step 1).

The backbone of a snakesim robot is the chain of bend-joint origins from the
tail link's origin to the tip of the last module (the URDF child frame of a
joint is the joint frame, so a bend's vertex is its child link's origin; the
robot axis is +x, tail to head). Between two vertices the chain is rigid at
zero twist: a fixed vector ``v_rel`` in the bend's frame (for the designs in
snakesim.robots it lies on x, so twists do not move the next vertex).

Chord walk. Vertices are put ON the target curve c(s): from the current
vertex V_i, the next V_{i+1} is the first curve point past V_i's arc
parameter at chord distance |v_rel_i| (linear interpolation between dense
samples); the module's target direction is d_i = (V_{i+1} − V_i)/|v_rel_i|.
Aiming from the ACTUAL vertex (not the ideal one) lets errors of an
unreachable direction be corrected by the following modules.

Angles, tail to head (one pass, no iteration):
- base: tail position c(0); tail x axis = d_0, rolled about d_0 so that the
  first bend's plane contains d_1 (the smaller of the two rolls).
- bend about axis â (joint frame): b = atan2(â·(u×d), u·d) with u = v̂_rel and
  d the target direction, both projected on the plane ⟂ â (exact when d is
  in that plane, the best in-plane direction otherwise); clipped to limits.
- twist about the module axis ê: chosen so that the NEXT bend's axis â(t) is
  ⟂ to the next target direction d_{i+1}, i.e. (â·d) cos t + ((ê×â)·d) sin t = 0,
  the root of smaller |t| (the next bend's sign absorbs the other); 0 when d is
  along ê (straight ahead) or no bend follows.
- screws and every other joint: 0.

What each design represents:
- bend (pitch) + twist per module (eels-1.0, eels-1.0-front, eels-1.5): any
  curve whose turning angle per module is within the bend limit (±45°), 3D
  included: the twist before each bend sets its plane, so helices, arcs and
  S-curves are fitted exactly at the vertices (residual ~ the dense sampling).
- alternating pitch/yaw bends, no twist (eels-concept, mini-eels-1.0): planar
  curves in a bend plane exactly when consecutive bends share it, i.e. a
  crescent or S-curve in the plane of every other joint; in general (a helix)
  each bend takes the in-plane part of its target direction and the
  residual (reported) grows with the out-of-plane part.
- pitch bends only, no twist: curves in one plane (the base roll picks it).

Limits are not in the multibody's URDF parse; ``limits`` gives them per joint
kind (defaults: the snakesim.robots URDFs' ±π/4 bend, ±π/2 twist).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from snakesim.components.multibody.robot_model import RobotModel, joint_kind

from .shapes import Shape, world_curve

DEFAULT_LIMITS = {"bend": math.pi / 4, "twist": math.pi / 2}


class PlacementError(ValueError):
    """The shape cannot be fitted (the message says which vertex and why)."""


@dataclasses.dataclass(frozen=True)
class Placement:
    q0: dict[str, float]                  # every DOF joint, rad (screws 0)
    base_position: tuple[float, float, float]
    base_quaternion: tuple[float, float, float, float]   # (x, y, z, w) of the tail link
    vertices: np.ndarray                  # (m, 3) backbone points reached (tail origin, bend origins, tip), world
    residual: float                       # m, largest distance of a vertex from the curve
    clipped: tuple[str, ...]              # joints whose fitted angle was clipped to its limit


def curve_distance(pts: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance (m) of each of ``points`` (m, 3) from the polyline ``pts`` (n, 3)."""
    a, ab = pts[:-1], np.diff(pts, axis=0)
    rel = points[:, None, :] - a[None]
    f = np.clip(np.einsum("mnk,nk->mn", rel, ab) / np.maximum(np.einsum("nk,nk->n", ab, ab), 1e-300), 0.0, 1.0)
    return np.linalg.norm(rel - f[..., None] * ab[None], axis=2).min(axis=1)


def _rot(axis, angle) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _quat_xyzw(R) -> tuple[float, float, float, float]:
    from scipy.spatial.transform import Rotation

    return tuple(float(v) for v in Rotation.from_matrix(R).as_quat())


def _wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def _roll_to_contain(axis_w, e, d) -> float:
    """Angle t about unit ``e`` that makes the rotated ``axis_w`` ⟂ ``d`` (smaller of the two roots)."""
    A, B = float(axis_w @ d), float(np.cross(e, axis_w) @ d)
    if math.hypot(A, B) < 1e-9:
        return 0.0
    t1 = math.atan2(-A, B)
    t2 = _wrap(t1 + math.pi)
    return t1 if abs(t1) <= abs(t2) else t2


def _bend_angle(axis, u, d) -> float:
    """Angle about unit ``axis`` turning u towards d (both projected on the plane ⟂ axis)."""
    u = u - (u @ axis) * axis
    d = d - (d @ axis) * axis
    if np.linalg.norm(d) < 1e-12 or np.linalg.norm(u) < 1e-12:
        return 0.0
    return math.atan2(float(axis @ np.cross(u, d)), float(u @ d))


class _Chord:
    """Chord walk on a dense curve: the first point past index k at distance L from P."""

    def __init__(self, pts: np.ndarray, what: str):
        self.pts, self.k, self.what = pts, 0, what

    def next(self, P, L, k0=None):
        pts = self.pts
        k0 = self.k if k0 is None else k0
        dist = np.linalg.norm(pts[k0:] - P, axis=1)
        hit = np.flatnonzero(dist >= L)
        if hit.size == 0:
            raise PlacementError(f"{self.what}: no point of the curve lies {L:.3f} m ahead of the vertex at "
                                 f"{np.round(P, 4).tolist()} (the curve turns too tightly for a {L:.3f} m module, "
                                 "or is too short)")
        j = k0 + int(hit[0])
        i = max(j - 1, k0)
        # linear interpolation of the crossing |c − P| = L between samples i and j
        di, dj = np.linalg.norm(pts[i] - P), np.linalg.norm(pts[j] - P)
        f = 0.0 if dj == di else min(max((L - di) / (dj - di), 0.0), 1.0)
        return pts[i] + f * (pts[j] - pts[i]), i


def _chain(tree, joints_dof, metadata=None):
    """Path joints root -> last module, the bend joints on it, and each bend's v_rel (child frame)."""
    bends = [j for j in joints_dof if joint_kind(j, metadata) == "bend"]
    if not bends:
        raise PlacementError("the robot has no bend joints (names 'bend*', or kind bend in its metadata): a shape "
                             "cannot be fitted; use shape kind 'joints'")
    # the last module: below the last bend, follow the moving non-screw joints (its twist)
    link = tree.joint_by_name[bends[-1]].child
    while True:
        nxt = [j for j in tree.children.get(link, []) if j.moving and joint_kind(j.name, metadata) not in ("screw",)]
        if not nxt:
            break
        link = nxt[0].child
    path, lk = [], link
    while lk in tree.parent_joint:
        j = tree.parent_joint[lk]
        path.append(j)
        lk = j.parent
    path.reverse()
    on_path = [j.name for j in path if joint_kind(j.name, metadata) == "bend"]
    v_rel = {}
    for a, b in zip(on_path, on_path[1:]):
        v_rel[a] = tree.placement_in(tree.joint_by_name[a].child, tree.joint_by_name[b].child)[1]
    last = tree.joint_by_name[on_path[-1]].child
    tips = [tree.placement_in(last, lk)[1] for lk in tree.subtree(last)]
    v_rel[on_path[-1]] = np.array([max(p[0] for p in tips), 0.0, 0.0])   # the farthest point along the axis
    v_tail = tree.placement_in(tree.root, tree.joint_by_name[on_path[0]].child)
    return path, on_path, v_rel, v_tail


def fit_shape(robot: RobotModel, shape: Shape | dict, limits: dict[str, float] | None = None) -> Placement:
    """Initial joint angles and tail pose putting ``robot``'s backbone on ``shape`` (see module doc).

    ``robot``: the built robot (:class:`RobotModel`, e.g. ``RobotModel.load(design="eels-1.5", modules=4)``
    or the multibody's). ``limits``: symmetric limit (rad) per joint kind.
    """
    if not isinstance(robot, RobotModel):
        raise TypeError(f"fit_shape: 'robot' must be a RobotModel (RobotModel.load(design=..., modules=...) or "
                        f"a multibody's .robot), got {type(robot).__name__}")
    shape = shape if isinstance(shape, Shape) else Shape(**shape)
    lim = dict(DEFAULT_LIMITS, **(limits or {}))
    tree, names = robot.tree, list(robot.joints)
    R_pose, P0 = shape.pose.rotation(), np.asarray(shape.pose.position, float)
    if shape.kind == "joints":
        from snakesim.components.multibody.model import match_values

        q = shape.q
        if isinstance(q, list):
            if len(q) != len(names):
                raise PlacementError(f"shape.q has {len(q)} values but the robot has {len(names)} DOF joints: "
                                     f"{', '.join(names)}")
            q = dict(zip(names, q))
        q0 = {n: 0.0 for n in names}
        q0.update({k: float(v) for k, v in match_values(names, q, "shape.q").items()})
        return Placement(q0, tuple(P0), _quat_xyzw(R_pose), P0[None, :], 0.0, ())

    path, bends, v_rel, (R_b0, p_b0) = _chain(tree, names, robot.metadata)
    length = float(np.linalg.norm(p_b0) + sum(np.linalg.norm(v) for v in v_rel.values()))
    pts = world_curve(shape, 3.0 * length + 1.0)
    chord = _Chord(pts, f"shape '{shape.kind}'")
    angles = {n: 0.0 for n in names}
    clipped = []

    def clip(name, a):
        m = lim.get(joint_kind(name, robot.metadata), math.inf)
        if abs(a) > m:
            clipped.append(name)
            return math.copysign(m, a)
        return a

    # base: x of the tail along d_0, rolled so bend_0's plane holds d_1
    V0 = pts[0]
    L0 = float(np.linalg.norm(p_b0))
    V1, k1 = chord.next(V0, L0)
    d0 = (V1 - V0) / L0
    u0 = p_b0 / L0
    Ra = R_pose
    w = np.cross(Ra @ u0, d0)
    if np.linalg.norm(w) > 1e-12:
        Ra = _rot(w, math.atan2(np.linalg.norm(w), float((Ra @ u0) @ d0))) @ Ra
    elif (Ra @ u0) @ d0 < 0:
        Ra = _rot(R_pose[:, 2], math.pi) @ Ra
    j0 = tree.joint_by_name[bends[0]]
    V2, _ = chord.next(V1, float(np.linalg.norm(v_rel[bends[0]])), k1)
    d1 = (V2 - V1) / np.linalg.norm(V2 - V1)
    R = _rot(d0, _roll_to_contain(Ra @ R_b0 @ j0.axis, d0, d1)) @ Ra
    p = V0.copy()
    R_base, p_base = R.copy(), p.copy()
    vertices = [V0]

    for idx, j in enumerate(path):
        Rj, pj = R @ j.rotation, p + R @ j.translation
        kind = joint_kind(j.name, robot.metadata)
        a = 0.0
        if kind == "bend" and j.name in v_rel:
            L = float(np.linalg.norm(v_rel[j.name]))
            target, k = chord.next(pj, L)
            chord.k = k
            vertices.append(pj)
            a = clip(j.name, _bend_angle(j.axis, v_rel[j.name] / L, Rj.T @ (target - pj) / L))
        elif kind == "twist" and j.is_dof:
            nxt = next((m for m in range(idx + 1, len(path)) if path[m].name in v_rel), None)
            if nxt is not None:
                Rh, ph = Rj, pj                        # the next bend's joint frame, this twist at zero
                for jj in path[idx + 1:nxt + 1]:
                    Rh, ph = Rh @ jj.rotation, ph + Rh @ jj.translation
                hb = path[nxt]
                L = float(np.linalg.norm(v_rel[hb.name]))
                target, _ = chord.next(ph, L)
                a = clip(j.name, _roll_to_contain(Rh @ hb.axis, Rj @ j.axis, (target - ph) / L))
        if j.is_dof:
            angles[j.name] = a
        R, p = (Rj @ _rot(j.axis, a) if j.moving else Rj), pj
        if j.name == bends[-1]:
            tip = p + R @ v_rel[j.name]        # later twists turn about the axis: the tip stays
    vertices.append(tip)
    V = np.array(vertices)
    residual = float(curve_distance(pts, V).max())
    return Placement({n: float(angles[n]) for n in names}, tuple(float(v) for v in p_base), _quat_xyzw(R_base),
                     V, residual, tuple(clipped))
