"""Hand a settled, pre-loaded placement over to a hold run (paper 2.2.6: "the autonomy system then
takes over ... gravity is re-enabled").

``held_state`` reads off a placement run (assemblies/lib/placement-scene.yaml) at its last
sample: every DOF joint angle, the tail link's pose, and the settle component's latched
pre-load torques; the set-points are the angles themselves (the loaded shape).
``hold_overrides`` turns that into ``--set`` items for a hold scene
(assemblies/lib/placement-hold.yaml), which starts there at rest with gravity on.

Why two runs and not one: between walls the pre-load squeezes the robot into a shape whose
screws must slide ~F/k (≈ 1 mm at 100 N on the 1e5 N/m ice) along the walls to
carry the pre-load's frictionless distribution; with the regularised friction that slide
creeps at ≲ v_ε, i.e. seconds at the small v_ε a creep-free hold needs (and at high μ the
squeeze locks in a low-force state). The placement is a solver, not the experiment: it
settles and pre-loads with the terrain's own (low) friction, and the hold run starts from
its state with the wall friction under test. Same state for every μ: hold and slip
differ by the friction only.

Hold limit (an upright robot, gravity along its axis, every screw force along the wall
normal): the walls' friction can carry at most μ ΣF_n, so the robot slides unless
μ ≥ μ* = m g / ΣF_n (a necessary condition; with the regularised law it is also what
sets the steady creep: a rigid body sinking at v has friction μ ΣF_n v/sqrt(v² + v_ε²)
= m g, i.e. v = v_ε r/sqrt(1 − r²), r = μ*/μ). Below μ* the robot slides with
a = g (1 − μ/μ*) (friction saturated once v ≫ v_ε).
"""

from __future__ import annotations

import json

import numpy as np

from .settle import SettlePhase


def held_state(session, result, prefix: str = "placement-scene/") -> dict:
    """The placement run's loaded state as hold-scene parameters: q, pose (tail), setpoint and tau_ff
    (DOF joints in URDF order), nj. Read at the last sample of the loading phase (SettlePhase.LOADING: pre-load
    on, gravity still off), so the run may go on into its own hold. The run must record
    settle.phase, robot.joint_q, robot.link_poses and settle.tau_ff."""
    phase = np.asarray(result[prefix + "settle.phase"][:, 0])
    loading = np.flatnonzero(phase == SettlePhase.LOADING)
    if loading.size == 0:
        raise ValueError(f"held_state: the placement run has no loading phase (phase reached {phase.max():g}): "
                         "run it past the latch, with settle load_time > 0")
    i = int(loading[-1])
    q = np.asarray(result[prefix + "robot.joint_q"][i], float)
    tail = np.asarray(result[prefix + "robot.link_poses"][i], float).reshape(-1, 7)[0]
    tau = np.asarray(result[prefix + "settle.tau_ff"][i], float)
    return {"q": [float(v) for v in q],
            "pose": {"position": [float(v) for v in tail[:3]], "quaternion": [float(v) for v in tail[3:]]},
            "setpoint": [float(v) for v in q], "tau_ff": [float(v) for v in tau], "nj": len(q)}


def hold_overrides(state: dict) -> list[str]:
    """``--set`` items (load_session overrides) putting ``state`` into a hold scene."""
    return [f"{k}={json.dumps(v)}" for k, v in state.items()]


def gravity_preload(robot, state: dict, links, points, normals, total: float,
                    gravity=(0.0, 0.0, -9.81)) -> tuple[list[float], np.ndarray, float]:
    """Pre-load torques that hold ``state`` (held_state's q and tail pose) still WITH gravity: the
    self-equilibrated pre-load of the settle (Σ F n̂ = 0) is right with gravity off, but once the weight
    hangs on the walls the bends must also carry the weight's moments, or the brace redistributes
    (the 3-point brace between walls unloads its lowest screw and slides).

    Contacts s (on link ``links[s]``, world point p_s, normal n̂_s: the wall's push on the robot, the
    terrain's outward normal) carry f_s = N_s n̂_s + t_s, t_s ⊥ n̂_s. Static balance of the free flyer
    (Pinocchio's generalised gravity g(q) = τ + Σ J_sᵀ f_s with τ = 0 on its six rows) and Σ N_s = ``total``
    are imposed; among the solutions the one with t_s nearest to c N_s û_s (c = m g/``total``, û_s the
    unit tangential part of −gravity at s) is taken, N_s ≥ 0: friction against gravity in proportion to
    the normal load, as a rigid body creeping at the regularised friction's common slip speed has it
    (every contact at the same r = |t|/(μ N)), tilted only as far as the moments need. The joint rows
    then give τ. Screws get 0 (their brake holds them: the friction's moment about a screw axis is the
    brake's).

    Returns (tau per DOF joint in URDF order, N per contact, the largest |t_s|/N_s: the friction
    coefficient the hold needs)."""
    import pinocchio as pin
    from scipy.optimize import lsq_linear

    points, normals = np.asarray(points, float), np.asarray(normals, float)
    model = pin.buildModelFromXML(robot.urdf, pin.JointModelFreeFlyer())
    model.gravity.linear[:] = gravity
    data = model.createData()
    x = pin.neutral(model)
    x[:3], x[3:7] = state["pose"]["position"], state["pose"]["quaternion"]
    for name, v in zip(robot.joints, state["q"]):
        j = model.joints[model.getJointId(name)]
        if j.nq == 1:
            x[j.idx_q] = v
        else:                                               # continuous joint: (cos, sin)
            x[j.idx_q:j.idx_q + 2] = np.cos(v), np.sin(v)
    g = pin.computeGeneralizedGravity(model, data, x).copy()
    mg = float(np.linalg.norm(g[:3]))                       # the free flyer's force rows: the weight
    pin.computeJointJacobians(model, data, x)
    pin.updateFramePlacements(model, data)
    n = len(points)
    up = -np.asarray(gravity, float) / max(np.linalg.norm(gravity), 1e-300)
    u = up - np.einsum("si,i->s", normals, up)[:, None] * normals
    u /= np.maximum(np.linalg.norm(u, axis=1), 1e-12)[:, None]
    e2 = np.cross(normals, u)                                # tangent basis (û, ê2) per contact
    # unknowns z = [N_s, a_s, b_s]: f_s = N_s n̂_s + a_s û_s + b_s ê2_s; G z = Σ J_sᵀ f_s
    G = np.zeros((model.nv, 3 * n))
    for s_, (link, p) in enumerate(zip(links, points)):
        fid = model.getFrameId(link)
        J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
        o = data.oMf[fid].translation
        JT = (J[:3] + pin.skew(o - p) @ J[3:]).T             # point Jacobian transposed (nv, 3)
        G[:, s_], G[:, n + s_], G[:, 2 * n + s_] = JT @ normals[s_], JT @ u[s_], JT @ e2[s_]
    c = mg / total
    w = 1e4                                                 # equalities by a heavy penalty, N ≥ 0 by bounds
    A = np.vstack([w * G[:6], w * np.r_[np.ones(n), np.zeros(2 * n)][None],
                   np.hstack([-c * np.eye(n), np.eye(n), np.zeros((n, n))]),
                   np.hstack([np.zeros((n, 2 * n)), np.eye(n)])])
    rhs = np.concatenate([w * g[:6], [w * total], np.zeros(2 * n)])
    lo = np.r_[np.zeros(n), np.full(2 * n, -np.inf)]
    z = lsq_linear(A, rhs, bounds=(lo, np.full(3 * n, np.inf)), tol=1e-12, lsmr_tol="auto").x
    tau = g - G @ z
    # forces to 1e-6 of the load, moments to 1e-4 m × the load: contacts ~µm off one plane leave a moment
    # about the normal that the weak tangential terms carry
    if np.abs(tau[:3]).max() > 1e-6 * total * 10 or np.abs(tau[3:6]).max() > 1e-4 * total:
        raise ValueError(f"gravity_preload: no brace with normal loads ≥ 0 balances the weight at these contacts "
                         f"(free-flyer residual {np.abs(tau[:6]).max():.3g}); N = {np.round(z[:n], 3)}")
    N, a, b = z[:n], z[n:2 * n], z[2 * n:]
    out = []
    for name, kind in zip(robot.joints, robot.joint_kinds):
        j = model.joints[model.getJointId(name)]
        out.append(0.0 if kind == "screw" else float(tau[j.idx_v]))
    return out, N, float((np.hypot(a, b) / np.maximum(N, 1e-12)).max())
