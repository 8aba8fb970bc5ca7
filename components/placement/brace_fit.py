"""Which braces fit: a planar C of a robot between two parallel walls, chosen screws on chosen walls, no body
in a wall.

A design question to answer before simulating (paper 4.3.1: can EELS 1.5 hold itself in a crevasse of
width w, and how?). The tail's offset y₀ across the gap and the bend angles θ (twists 0, so the C is
planar) are fitted so that each chosen screw's outermost collision sample comes to within 1 mm of its wall
(the placement's attraction springs close the rest and pre-load it), and every other collision sample (the bodies, the free
screws) stays ``clearance`` clear of both walls, the bends within ``bend_limit``::

    min over (y₀, θ)   Σ_s (100 (σ_s y_s*(θ, y₀) − (w/2 − 1 mm)))²  +  1e6 Σ_p max(|y_p(θ, y₀)| − (w/2 − clearance), 0)²
    y_s* = max over screw s's samples of σ_s y   (σ_s = +1 for the +y wall, −1 for the −y wall)

Frames: walls at y = ±w/2 (the parallel_walls terrains), the robot's axis along +z with the tail lowest
(at z = 0.1 m), its bend axes along world x so the C lies in the y-z plane: tail quaternion
[x, y, z, w] = [−0.5, −0.5, −0.5, 0.5] (link x → world z, link y → world x). Kinematics by Pinocchio on the
robot's URDF; samples are the body contact's (components/contact/body_samples.py) on every link, screws
included. Multi-start L-BFGS-B from seeded random starts: a fit with a residual is evidence, not proof,
that no such brace exists (more starts, more evidence).

Used for placement-walls-body.yaml: for EELS 1.5 in 0.35 m the 4-screw C (screws 0 and 3 on one wall, 1 and
2 on the other) leaves screws 0 and 1 ~4-5 cm short of their walls once the bodies must stay out; the
3-point C (0 and 3 on +y, 2 on −y, 1 free) fits exactly.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from snakesim.components.contact.body_samples import BodySampleOptions, body_samples
from snakesim.components.multibody.robot_model import RobotModel

from .batched_fd import padded_groups

#: tail orientation of the fit: link x (the robot axis) -> world z, link y (bend axes) -> world x
UPRIGHT_IN_GAP = (-0.5, -0.5, -0.5, 0.5)
TAIL_Z = 0.1            # m
GAP_LEFT = 0.001        # m, how close to its wall a touching screw's outermost sample comes


@dataclasses.dataclass(frozen=True)
class BraceFit:
    """q: DOF joint angles in ``robot.joints`` order (rad); pose: the tail's {position, quaternion};
    reach_error: m per touching screw, σ y* − (w/2 − GAP_LEFT) (0: within GAP_LEFT of its wall); overrun: m,
    the deepest non-touching sample past w/2 − clearance; feasible: every |reach_error| < 1 mm and overrun
    < 0.5 mm."""

    q: list[float]
    pose: dict
    reach_error: dict[int, float]
    overrun: float
    feasible: bool


def sampled_robot(robot: RobotModel, spacing: float):
    """The robot's Pinocchio model (free-flyer root) and data, the body contact's samples on every link's
    collision shapes (screws included) at ``spacing`` m, each sample's link row, the links' frame ids and
    the rows that carry samples: what a brace fit poses and checks against the terrain."""
    import pinocchio as pin

    model = pin.buildModelFromXML(robot.urdf, pin.JointModelFreeFlyer())
    S = body_samples(robot, BodySampleOptions(spacing=spacing, exclude_screws=False))
    link_of = np.repeat(S.piece_link, np.diff(S.start))
    frames = [model.getFrameId(n) for n in robot.links]
    return model, model.createData(), S, link_of, frames, np.unique(link_of)


def fit_planar_brace(robot: RobotModel, gap: float, walls: dict[int, int], bend_limit: float,
                     clearance: float = 0.005, starts: int = 25, seed: int = 0, spacing: float = 0.02) -> BraceFit:
    """The best planar C of ``robot`` in a gap ``gap`` m wide with screw k (index in the design's screw list)
    on the wall of sign ``walls[k]`` (+1: +y, −1: −y). ``bend_limit`` rad bounds every bend joint."""
    import pinocchio as pin
    from scipy.optimize import minimize

    if not gap > 0 or not bend_limit > 0 or not walls or any(v not in (-1, 1) for v in walls.values()):
        raise ValueError(f"fit_planar_brace: need gap > 0, bend_limit > 0 and walls {{screw: ±1}}, got "
                         f"{gap}, {bend_limit}, {walls}")
    screws = robot.metadata.get("screws") or []
    if any(not 0 <= k < len(screws) for k in walls):
        raise ValueError(f"fit_planar_brace: screw indices must be in 0..{len(screws) - 1}, got {sorted(walls)}")
    model, data, S, link_of, frames, rows = sampled_robot(robot, spacing)
    touching = {robot.links.index(screws[k]["link"]): (k, s) for k, s in walls.items()}
    free = ~np.isin(link_of, list(touching))
    bends = [j for j, kind in zip(robot.joints, robot.joint_kinds) if kind == "bend"]
    iq = [model.joints[model.getJointId(j)].idx_q for j in bends]
    half = gap / 2

    def configuration(x):
        q = pin.neutral(model)
        q[:3] = [0.0, x[0], TAIL_Z]
        q[3:7] = UPRIGHT_IN_GAP
        q[iq] = x[1:]
        return q

    # each link's samples as one (k, 3) block (padded): y = block @ R[1] + t[1] for every link in one product
    padded, slot = padded_groups(np.searchsorted(rows, link_of), S.points, len(rows))
    row_frames = [frames[row] for row in rows]

    def lateral(x):
        pin.framesForwardKinematics(model, data, configuration(x))
        H = np.array([data.oMf[f].homogeneous for f in row_frames])
        return ((padded @ H[:, 1, :3, None])[..., 0] + H[:, 1, 3, None]).reshape(-1)[slot]

    def residuals(x):
        y = lateral(x)
        reach = {k: float((s * y[link_of == row]).max() - (half - GAP_LEFT)) for row, (k, s) in touching.items()}
        return reach, np.maximum(np.abs(y[free]) - (half - clearance), 0.0)

    def cost(x):
        reach, over = residuals(x)
        return 1e4 * sum(v * v for v in reach.values()) + 1e6 * float(over @ over)

    rng = np.random.default_rng(seed)
    bounds = [(-half, half)] + [(-bend_limit, bend_limit)] * len(bends)
    best = None
    for _ in range(starts):
        x0 = np.concatenate([[rng.uniform(-half / 2, half / 2)], rng.uniform(-bend_limit, bend_limit, len(bends))])
        res = minimize(cost, x0, bounds=bounds, method="L-BFGS-B")
        if best is None or res.fun < best.fun:
            best = res
    reach, over = residuals(best.x)
    q = dict(zip(bends, best.x[1:]))
    return BraceFit(q=[float(q.get(j, 0.0)) for j in robot.joints],
                    pose={"position": [0.0, float(best.x[0]), TAIL_Z], "quaternion": list(UPRIGHT_IN_GAP)},
                    reach_error=reach, overrun=float(over.max(initial=0.0)),
                    feasible=all(abs(v) < 1e-3 for v in reach.values()) and float(over.max(initial=0.0)) < 5e-4)
