"""Braces across a round vertical tube: which fit, and the lean a rolling descent needs (issue 15).

Rolling (no slip) a screw turning at ω about its axis â, touching the wall at ê_r (the outward radial),
moves its centre at v = −ω r (â × ê_r). In the wall's tangent frame (ê_φ = ẑ × ê_r, ẑ), with
â = a_r ê_r + a_φ ê_φ + a_z ẑ::

    v = −ω r (a_z ê_φ − a_φ ẑ)

A brace in a plane through the tube's axis has a_φ = 0 at every screw: v is horizontal, the robot can only
orbit the axis. If every bracing screw's axis leans by the same λ about its own radial, a_φ = tan λ · a_z,
spins ω_j = C / a_z,j move every contact at −C r (ê_φ − tan λ ẑ): one rigid screw motion, orbiting at
Ω = C r / R and sinking (or rising) at V = C r tan λ. Leaning both sides of a C the same way about their own
radials needs the chain to twist (turning a planar C about one wall's normal leans the sides oppositely).
The squeeze of three contacts balances with gravity off (Σ F n̂ = 0, Σ F p × n̂ = 0) only when their
radial normals lie on one line: the contacts on one plane through the axis, one between the other two.

:func:`fit_leaning_tube_brace` fits, from a nearby guess, the tail pose and the bends (and twists) inside
``limit_margin`` of their URDF limits so that each bracing screw's thread envelope reaches ``depth`` into
the wall (the extremal ring point, as the screw contact's), every other collision sample (bodies, free
screws) stays ``clearance`` clear by the terrain's signed distance, each bracing screw leans by λ, and
optionally each sits on its side of the plane x = 0 through the axis with its centre on it (``sides``)::

    min  Σ_k (1e2 (D_k − depth))² + 1e6 Σ_p max(clearance − d_p, 0)² + Σ_k (10 (a_φ,k cos λ − a_z,k sin λ))²
         + Σ_k (1e2 max(0.05 − s_k y_k, 0))² + Σ_k (1e2 x_k)² + 1e-4 ‖x‖²

(least squares, seeded multi-start). :func:`narrowest_vertical_tube` measures the narrowest vertical tube a
rigid cluster of links fits in over its orientations: for EELS 1.5, module 1 with its 0.4 m cross bar and the
avionics box needs r ≥ 0.2024 m, so no EELS 1.5 keeps its bodies out of the 0.35 m tube.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from snakesim.components.multibody.robot_model import RobotModel

from .brace_fit import sampled_robot


@dataclasses.dataclass(frozen=True)
class LeaningBrace:
    """q: DOF joint angles (robot.joints order, rad); pose: the tail's {position, quaternion [x, y, z, w]};
    depth: m per bracing screw (thread envelope into the wall); lean: rad per bracing screw,
    atan(a_φ / a_z); a_z: per bracing screw, its axis' vertical component; overrun: m, the worst other sample
    inside ``clearance``; feasible: every |depth − target| < 0.5 mm, |lean − λ| < 0.5°, overrun < 0.5 mm."""

    q: list[float]
    pose: dict
    depth: dict[int, float]
    lean: dict[int, float]
    a_z: dict[int, float]
    overrun: float
    feasible: bool


def fit_leaning_tube_brace(robot: RobotModel, terrain, q: list[float], pose: dict, screws: list[int],
                           lean: float, depth: float = -0.001, clearance: float = 0.005,
                           limit_margin: float = 0.05, spacing: float = 0.02, starts: int = 1,
                           seed: int = 0, kinds: tuple[str, ...] = ("bend", "twist"),
                           sides: dict[int, int] | None = None, lean_weight: float = 10.0) -> LeaningBrace:
    """The brace (module docstring) nearest the guess ``q`` / ``pose`` with bracing ``screws`` (indices in the
    design's screw list) leaning by ``lean`` rad. ``terrain``: a vertical tube (axis z through the origin).
    ``starts`` > 1 adds seeded random perturbations of the guess (tail ±3 cm and ±0.3 rad, joints within half
    their range): the best is returned; a residual in every start is evidence that no such brace is near.
    ``kinds``: the joint kinds fitted (("bend",): twists kept as in ``q``). ``sides``: screw -> ±1, the sign of
    its centre's world y (at least 5 cm off the axis), and every bracing screw's centre on the plane x = 0
    through the axis: which wall each screw presses, so that the squeeze can balance (radial normals in one
    plane, a contact on one side between two on the other, above and below it). ``lean_weight``: the lean
    residuals' weight (10 in the formula above)."""
    import pinocchio as pin
    from scipy.optimize import least_squares
    from scipy.spatial.transform import Rotation

    meta = robot.metadata.get("screws") or []
    if not screws or any(not 0 <= k < len(meta) for k in screws):
        raise ValueError(f"fit_leaning_tube_brace: screws must be indices in 0..{len(meta) - 1}, got {screws}")
    if len(q) != len(robot.joints):
        raise ValueError(f"fit_leaning_tube_brace: q has {len(q)} angles, the robot {len(robot.joints)} joints")
    model, data, S, link_of, frames, rows = sampled_robot(robot, spacing)
    touching = {robot.links.index(meta[k]["link"]): k for k in screws}
    radius = {k: float(meta[k]["radius"]) for k in screws}
    ring_x = {k: 0.5 * float(meta[k]["length"]) * np.array([-1.0, 0.0, 1.0]) for k in screws}
    free = ~np.isin(link_of, list(touching))
    lo, hi = robot.position_limits()
    shaped = [i for i, kind in enumerate(robot.joint_kinds) if kind in kinds]
    # one-coordinate joints (bends, twists) take q; continuous ones (screws: (cos, sin) in Pinocchio) keep
    # the neutral (1, 0): writing their angle 0 into cos collapsed the screw links' rotation
    hinge = [i for i, j in enumerate(robot.joints) if model.joints[model.getJointId(j)].nq == 1]
    iq = [model.joints[model.getJointId(robot.joints[i])].idx_q for i in hinge]
    q0 = np.asarray(q, dtype=float)
    p0 = np.asarray(pose["position"], dtype=float)
    R0 = Rotation.from_quat(pose["quaternion"])
    sl, cl = np.sin(lean), np.cos(lean)

    def state(x):
        qq = q0.copy()
        qq[shaped] += x[6:]
        return p0 + x[:3], Rotation.from_rotvec(x[3:6]) * R0, qq

    def kinematics(x):
        p, R, qq = state(x)
        c = pin.neutral(model)
        c[:3], c[3:7] = p, R.as_quat()
        c[iq] = qq[hinge]
        pin.framesForwardKinematics(model, data, c)
        out = np.empty((len(link_of), 3))
        for row in rows:
            m = link_of == row
            M = data.oMf[frames[row]]
            out[m] = S.points[m] @ M.rotation.T + M.translation
        screw = {}
        for row, k in touching.items():
            M = data.oMf[frames[row]]
            ax = M.rotation[:, 0]                       # screw axis: the screw link's x
            screw[k] = (M.translation + np.outer(ring_x[k], ax), ax, M.translation)
        return out, screw

    def measures(x):
        P, screw = kinematics(x)
        d = terrain.distance(P)
        deep, phi, az = {}, {}, {}
        for k, (c, ax, centre) in screw.items():
            qr = terrain.query(c)
            deep[k] = float((radius[k] * np.sqrt(np.clip(1.0 - (qr.normal @ ax) ** 2, 0.0, 1.0))
                             - qr.distance).max())
            er = np.array([centre[0], centre[1], 0.0]) / max(np.hypot(centre[0], centre[1]), 1e-9)
            ephi = np.array([-er[1], er[0], 0.0])
            phi[k], az[k] = float(ax @ ephi), float(ax[2])
        return deep, phi, az, np.maximum(clearance - d[free], 0.0), {k: v[2] for k, v in screw.items()}

    def residuals(x):
        deep, phi, az, over, centre = measures(x)
        r = [1e2 * (deep[k] - depth) for k in screws]
        r += [lean_weight * (phi[k] * cl - az[k] * sl) for k in screws]
        if sides:
            r += [1e2 * max(0.05 - s * centre[k][1], 0.0) for k, s in sides.items()]
            r += [1e2 * centre[k][0] for k in sides]           # centres on the diametral plane x = 0
        return np.concatenate([r, 1e3 * over, 1e-2 * x])

    bounds_lo = np.concatenate([np.full(6, -np.inf), [lo[i] + limit_margin - q0[i] for i in shaped]])
    bounds_hi = np.concatenate([np.full(6, np.inf), [hi[i] - limit_margin - q0[i] for i in shaped]])
    rng = np.random.default_rng(seed)
    res = None
    for start in range(starts):
        x0 = np.zeros(6 + len(shaped))
        if start:           # a seeded random perturbation of the guess
            x0[:3] = rng.uniform(-0.03, 0.03, 3)
            x0[3:6] = rng.uniform(-0.3, 0.3, 3)
            x0[6:] = rng.uniform(0.5 * bounds_lo[6:], 0.5 * bounds_hi[6:])
        x0 = np.clip(x0, bounds_lo + 1e-9, bounds_hi - 1e-9)
        r = least_squares(residuals, x0, bounds=(bounds_lo, bounds_hi), x_scale=1.0, max_nfev=400)
        if res is None or r.cost < res.cost:
            res = r
    deep, phi, az, over, _ = measures(res.x)
    p, R, qq = state(res.x)
    leans = {k: float(np.arctan(phi[k] / az[k])) if abs(az[k]) > 1e-9 else np.pi / 2 for k in screws}
    ov = float(over.max(initial=0.0))
    return LeaningBrace(q=[float(v) for v in qq],
                        pose={"position": [float(v) for v in p], "quaternion": [float(v) for v in R.as_quat()]},
                        depth=deep, lean=leans, a_z=az, overrun=ov,
                        feasible=(all(abs(deep[k] - depth) < 5e-4 for k in screws) and ov < 5e-4
                                  and all(abs(leans[k] - lean) < np.radians(0.5) for k in screws)))


def narrowest_vertical_tube(robot: RobotModel, links: list[str], orientations: int = 400, seed: int = 1,
                            spacing: float = 0.01) -> tuple[float, np.ndarray]:
    """The radius of the narrowest vertical cylinder the rigid cluster of ``links`` (fixed to one another: a
    module and what is mounted on it) fits in, over its orientations, and that orientation (3×3, the
    cluster's first link's axes in the world): seeded random orientations refined by Nelder-Mead, each scored
    by the smallest circle enclosing the horizontal projection of the links' collision samples. A search
    (an upper bound on the true minimum, evidence that a narrower tube cannot take the cluster)."""
    import pinocchio as pin
    from scipy.optimize import minimize
    from scipy.spatial.transform import Rotation

    model, data, S, link_of, _, _ = sampled_robot(robot, spacing)
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    base = data.oMf[model.getFrameId(links[0])]
    pts = []
    for name in links:
        M = data.oMf[model.getFrameId(name)]
        P = S.points[link_of == robot.links.index(name)] @ M.rotation.T + M.translation
        pts.append((P - base.translation) @ base.rotation)          # in the first link's frame
    P = np.vstack(pts)

    def circle(p2):
        f = lambda c: float(np.sqrt(((p2 - c) ** 2).sum(1)).max())  # noqa: E731
        return minimize(f, p2.mean(0), method="Nelder-Mead", options={"xatol": 1e-5, "fatol": 1e-6}).fun

    def radius(R):
        return circle((P @ R.T)[:, :2])

    best = min(Rotation.random(orientations, random_state=seed), key=lambda R: radius(R.as_matrix()))
    res = minimize(lambda v: radius((Rotation.from_rotvec(v) * best).as_matrix()), np.zeros(3), method="Nelder-Mead")
    return float(res.fun), (Rotation.from_rotvec(res.x) * best).as_matrix()
