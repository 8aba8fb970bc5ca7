"""A pre-loaded braced state between walls for the melt scene on ice friction (issue 28): the hand-made walls
brace (melt-dwell-climb.yaml's ``q`` and ``pose``) moved to where each screw presses its wall as hard as the
gravity pre-load asks, so the run starts in static equilibrium with gravity on.

Why not placement's ``shaft_brace``: it bounds the bends by their URDF limits, and the walls scenes' brace
spans the 0.35 m gap only past bend_02's 45° (those scenes run without joint stops); its 3-point brace within
limits reaches the walls but not ~1 cm into them (a few mm short at 650 N). This module does that step for a
given pose, with the same pieces (world frame, z up; m, rad, N):

1. contacts: each screw's extremal thread point towards the wall (over its three rings, centre c, axis â,
   terrain distance d and normal n̂ at c: depth D = r sqrt(1 − (n̂·â)²) − d, the contact's deepest point);
2. loads: placement.handoff.gravity_preload at those points for a total ``preload``: N_k ≥ 0, the joint
   torques τ that hold the state still with gravity, and the friction |F_t|/F_n the hold needs;
3. refine: least squares over the tail pose (6) and the bends so that D_k = N_k/k_wall (the contact's
   F = k d), shifts along the walls kept small (‖x_shift‖², ‖10 x_turn‖², ‖1e-2 x_bends‖²); 2-3 twice.

The scene is position-held at its ``q`` (bend PID) with ``torque_pattern`` = τ as the brace's feed-forward at
A = 1: the held shape, the pre-load torques and the walls' springs balance at t = 0.

``required_preload(mass, mu, margin)``: the hold needs μ ΣF_n ≥ m g (the walls are vertical: friction alone
carries the weight), so ΣF_n = margin · m g / μ.
"""

from __future__ import annotations

import dataclasses

import numpy as np

G = 9.81  # m/s²


def required_preload(mass: float, mu: float, margin: float = 1.5) -> float:
    """N, the total wall load at which friction μ carries ``margin`` times the weight m g."""
    if mass <= 0 or mu <= 0 or margin <= 0:
        raise ValueError(f"required_preload: mass, mu and margin must be > 0, got {mass}, {mu}, {margin}")
    return margin * mass * G / mu


@dataclasses.dataclass(frozen=True)
class WallsPreload:
    """q: DOF joint angles (robot.joints order); pose: {position, quaternion [x, y, z, w]}; loads: N per screw;
    torques: N·m per bend/twist joint at A = 1; depth: m per screw into its wall; friction: the largest
    |F_t|/F_n the hold needs."""

    q: list[float]
    pose: dict
    loads: np.ndarray
    torques: dict[str, float]
    depth: np.ndarray
    friction: float


def walls_preload(robot, q, pose: dict, terrain, preload: float, screws=None) -> WallsPreload:
    """The pre-loaded state near (``q``, ``pose``) braced on ``screws`` (indices, all by default): module docstring."""
    import pinocchio as pin
    from scipy.optimize import least_squares
    from scipy.spatial.transform import Rotation

    from snakesim.components.contact.robot_screws import screw_layout
    from snakesim.components.placement.handoff import gravity_preload

    meta, lay = robot.metadata["screws"], robot.derived(screw_layout)
    screws = list(range(len(meta))) if screws is None else list(screws)
    model = pin.buildModelFromXML(robot.urdf, pin.JointModelFreeFlyer())
    data = model.createData()
    kinds = np.array(robot.joint_kinds)
    bends = np.flatnonzero(kinds == "bend")
    q0 = np.asarray(q, float)
    p0, R0 = np.asarray(pose["position"], float), Rotation.from_quat(pose["quaternion"])
    frames = [model.getFrameId(meta[k]["link"]) for k in screws]
    carriers = [robot.links[lay.parent_row[k]] for k in screws]
    radius = np.array([float(meta[k]["radius"]) for k in screws])
    rings = [0.5 * float(meta[k]["length"]) * np.array([-1.0, 0.0, 1.0]) for k in screws]

    def state(x):
        qq = q0.copy()
        qq[bends] += x[6:]
        return qq, p0 + x[:3], Rotation.from_rotvec(x[3:6]) * R0

    def measure(x):
        qq, pos, Rt = state(x)
        cfg = pin.neutral(model)
        cfg[:3], cfg[3:7] = pos, Rt.as_quat()
        for name, v in zip(robot.joints, qq):
            j = model.joints[model.getJointId(name)]
            if j.nq == 1:
                cfg[j.idx_q] = v
            else:                                                   # continuous joint: (cos, sin)
                cfg[j.idx_q:j.idx_q + 2] = np.cos(v), np.sin(v)
        pin.framesForwardKinematics(model, data, cfg)
        depth, point, normal, k_wall = [], [], [], []
        for s, fid in enumerate(frames):
            M = data.oMf[fid]
            a = M.rotation[:, 0]                                    # the screw axis: the screw link's x
            c = M.translation + np.outer(rings[s], a)
            qr = terrain.query(c)
            reach = radius[s] * np.sqrt(np.clip(1.0 - (qr.normal @ a) ** 2, 0.0, 1.0)) - qr.distance
            i = int(np.argmax(reach))
            e = -qr.normal[i] + (qr.normal[i] @ a) * a              # towards the wall, normal to the axis
            depth.append(reach[i])
            point.append(c[i] + radius[s] * e / max(np.linalg.norm(e), 1e-12))
            normal.append(qr.normal[i])
            k_wall.append(terrain.materials[int(qr.material[i])].k)
        return np.array(depth), np.array(point), np.array(normal), np.array(k_wall)

    x = np.zeros(6 + len(bends))
    _, point, normal, k_wall = measure(x)
    target = np.full(len(screws), preload / len(screws)) / k_wall
    for _ in range(2):
        x = least_squares(lambda z: np.concatenate([1e3 * (measure(z)[0] - target), z[:3], 10 * z[3:6],
                                                    1e-2 * z[6:]]), x, max_nfev=300).x
        depth, point, normal, k_wall = measure(x)
        qq, pos, Rt = state(x)
        st = {"q": [float(v) for v in qq],
              "pose": {"position": [float(v) for v in pos], "quaternion": [float(v) for v in Rt.as_quat()]}}
        tau, N, mu = gravity_preload(robot, st, carriers, point, normal, preload)
        target = N / k_wall
    torques = {j: float(t) for j, t, kd in zip(robot.joints, tau, kinds) if kd in ("bend", "twist")}
    return WallsPreload(st["q"], st["pose"], np.asarray(N), torques, depth, float(mu))
