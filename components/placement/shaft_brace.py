"""Place a braced robot in any shaft (issue 30): survey the shaft at a depth, fit a planar brace to the measured
width in the measured wall frame, refine it against the terrain's real distances, and derive the pre-load
that holds it with gravity on.

    robot:
      type: placed_multibody
      params: {design: eels-1.5, modules: 4,
               shape: {kind: shaft_brace, terrain: moulin-slot, depth: 3.5, xy: [1.2, 0.0],
                       brace: {screws: {0: 1, 2: -1, 3: 1}}, turn: -0.5585}}

Steps (world frame, z up; m, rad, N):

1. survey (shaft_survey.py) at P = (x, y, −depth): the walls' frame (ê_l long, n̂ normal, ê_v up), the
   width w between the two fitted wall planes, the mid-plane point C.
2. fit (brace_fit.fit_planar_brace): the planar C for the gap w with screw k on wall ``screws[k]`` (+1: the
   wall n̂ points to, −1 the other), bends within ``bend_limit``; in its frame the walls are y = ±w/2, the
   robot axis up z. It is put in the world by x_world = C + R_β [ê_l n̂ ê_v] (x_fit − (c_x, 0, c_z)), c the
   fit's centre of mass, R_β the turn by ``turn`` rad about n̂ through it (a turned brace rolls along its
   plane's normal, at ``turn`` below the horizontal: brace_climb).
3. refine against the terrain (a scanned wall is not a plane): least squares over the tail pose (6) and
   the bends, from the mapped fit::

       min  Σ_k (1e3 (D_k − δ_k))² + Σ_p (1e4 max(clearance − d_p, 0))² + ‖x_shift‖² + ‖10 x_turn‖²
            + ‖1e-2 x_bends‖²

   (x in m, rad: the pose terms keep the motions along a wall that change no distance, sliding and turning
   in its plane, near zero; a millimetre of depth weighs as 1 m or 0.1 rad there, so on a rough wall the
   brace slides a few cm to where it fits rather than miss its depths, but keeps its turn: its rolling
   direction and the modules' tilt)

   D_k: how deep bracing screw k's thread envelope reaches into the wall (over its three rings, centre c,
   axis â, the terrain's d and n̂ at c: r sqrt(1 − (n̂·â)²) − d, the screw contact's extremal point);
   d_p: the terrain's signed distance at every other collision sample (bodies, free screws: the body
   contact's samples at ``spacing``); δ_k = N_k/k_wall, the penetration at which the contact (F = k d)
   carries the load N_k of step 4 (first pass: the mean load). Where a rough wall leaves no such state
   (a depth missed by > 0.5 mm, a body inside the clearance), the brace is moved a few cm along the wall
   (``SHIFTS``) and refined again; the first spot that fits is taken (``ShaftPlacement.shift``).
   The Jacobian is scipy's forward differences, its steps posed and queried as one batch (batched_fd.py:
   the same numbers as one step at a time, ~4× faster); a step's d_p is measured only near the walls.
4. pre-load (handoff.gravity_preload): the joint torques that hold the refined state still WITH gravity,
   the bracing screws' loads N_k ≥ 0 summing to ``preload`` N, contacts at the rings' extremal points. Steps
   3-4 run twice (the second with each screw's own δ_k), so the state handed over is the static
   equilibrium of the position-held shape, the pre-load torques and the walls' springs: the settled state.

A placement that does not fit raises :class:`~.fit.PlacementError` naming the depth, the width measured and
what the brace reaches (screws short of their walls: the shaft is too wide; bodies in a wall: too narrow).
``place_in_shaft`` is memoised per robot and spec, so the multibody (its initial state) and the hand-over
(shaft_handover.py: the controller's base shape, torque pattern and climb signs, the wall loads' normal)
share one placement per process.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.components.contact.robot_screws import screw_layout
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Params

from .batched_fd import forward_differences, padded_groups, row_dot
from .brace_fit import fit_planar_brace, sampled_robot
from .fit import Placement, PlacementError
from .handoff import gravity_preload
from .shaft_survey import ShaftSurvey, survey_shaft
from .shapes import register_placer


#: rad: the fit's bends stay this far inside their URDF limits (0.74 of EELS 1.5's ±0.785, as
#: placement-walls-body's fit), room for the pre-load's squeeze and brace_climb's limit guard
LIMIT_MARGIN = 0.045
#: m: a free sample farther than this beyond the clearance is not measured in a Jacobian's steps (they move
#: it < 1e-6 m: its term stays 0)
NEAR = 0.01
#: m, (along the wall, up) shifts of the brace tried in turn when the refinement misses (a rough wall)
SHIFTS = ((0.0, 0.0), (0.0, 0.03), (0.0, -0.03), (0.05, 0.0), (-0.05, 0.0), (0.0, 0.06), (0.0, -0.06),
          (0.1, 0.0), (-0.1, 0.0))


class ShaftBraceSpec(Params):
    """The brace: which screw on which wall, and how far the bends may go."""

    screws: dict[int, Literal[-1, 1]] = Field(description="screw index (design order) -> wall: +1 the wall the "
                                              "survey's normal points to, −1 the other")
    bend_limit: float | None = Field(None, gt=0, description="rad, |bend| of the fit (None: the URDF limit − "
                                     "LIMIT_MARGIN)")
    starts: int = Field(6, ge=1, description="multi-start count of the planar fit")
    seed: int = 0


class ShaftBrace(Params):
    """Shape kind ``shaft_brace``: survey, fit, refine, pre-load (module docstring)."""

    kind: Literal["shaft_brace"] = "shaft_brace"
    terrain: str = Field(description="the terrain (name in terrains/ or path) the shaft is surveyed in")
    depth: float = Field(gt=0, description="m below z = 0 of the brace's centre of mass")
    xy: tuple[float, float] = Field(description="m, (x, y) guess on the shaft's axis at that depth")
    brace: ShaftBraceSpec
    turn: float = Field(0.0, description="rad, the brace turned about the wall normal (its rolling direction's "
                                         "angle below the horizontal)")
    plus_side: tuple[float, float] = Field((0.0, 1.0), description="horizontal (x, y): the + wall's side")
    clearance: float = Field(0.002, ge=0, description="m, every non-bracing collision sample this clear of the "
                             "walls, pre-loaded (the screws ~N/k into them)")
    preload: float = Field(650.0, gt=0, description="N, Σ of the bracing screws' wall loads at A = 1")
    spacing: float = Field(0.03, gt=0, description="m, collision sample spacing of the fit and the check "
                           "(body_contact's default: the samples that would touch)")
    patch: float = Field(0.3, gt=0, description="m, half-size of each wall patch the survey fits")

    def place(self, robot: RobotModel, limits: dict | None = None) -> Placement:
        pl = place_in_shaft(robot, self)
        return Placement(dict(zip(robot.joints, pl.q)), tuple(pl.pose["position"]), tuple(pl.pose["quaternion"]),
                         pl.contacts, pl.overrun, ())


register_placer(ShaftBrace)


@dataclasses.dataclass(frozen=True)
class ShaftPlacement:
    """q: DOF joint angles (robot.joints order, rad); pose: the tail's {position, quaternion [x, y, z, w]};
    survey: what the shaft measured; loads: N per bracing screw at A = 1 (gravity_preload);
    torques: N·m per DOF joint holding the state with gravity (screws 0); depth: m per bracing screw, its
    envelope into the wall (target loads/k); overrun: m, the deepest other sample inside ``clearance``;
    contacts: (n, 3) the bracing screws' contact points (world); friction: the largest |F_t|/F_n the hold
    needs; wall_sign: per screw joint name, the wall it presses (±1, 0 free); shift: m, (along the wall, up)
    from the surveyed point where it fitted (SHIFTS)."""

    q: list[float]
    pose: dict
    survey: ShaftSurvey
    loads: dict[int, float]
    torques: list[float]
    depth: dict[int, float]
    overrun: float
    contacts: np.ndarray
    friction: float
    wall_sign: dict[str, float]
    shift: tuple[float, float]

    def torque_pattern(self, robot: RobotModel) -> dict[str, float]:
        """The pre-load per bend/twist joint (N·m at A = 1), brace_climb's ``torque_pattern``."""
        return {j: t for j, t, k in zip(robot.joints, self.torques, robot.joint_kinds) if k in ("bend", "twist")}


@functools.lru_cache(maxsize=None)
def _terrain(name: str):
    from snakesim.components.terrain import load_terrain

    return load_terrain(name)


_PLACED: dict = {}


def place_in_shaft(robot: RobotModel, spec: ShaftBrace) -> ShaftPlacement:
    """The placement of the module docstring, memoised per (robot URDF, spec)."""
    key = (robot.urdf, spec.model_dump_json())
    if key not in _PLACED:
        _PLACED[key] = _place(robot, spec)
    return _PLACED[key]


def _place(robot: RobotModel, spec: ShaftBrace) -> ShaftPlacement:
    import pinocchio as pin
    from scipy.spatial.transform import Rotation

    terrain = _terrain(spec.terrain)
    P = np.array([spec.xy[0], spec.xy[1], -spec.depth])
    sv = survey_shaft(terrain, P, patch_long=spec.patch, patch_height=spec.patch, plus_side=spec.plus_side)
    kinds = np.array(robot.joint_kinds)
    lo, hi = robot.position_limits()
    lo, hi = lo + LIMIT_MARGIN, hi - LIMIT_MARGIN
    bend_limit = spec.brace.bend_limit or float(np.min(np.minimum(-lo[kinds == "bend"], hi[kinds == "bend"])))
    fit = fit_planar_brace(robot, sv.width, dict(spec.brace.screws), bend_limit, clearance=spec.clearance,
                           starts=spec.brace.starts, seed=spec.brace.seed, spacing=spec.spacing)
    where = (f"shaft_brace at depth {spec.depth:g} m, xy {list(spec.xy)} in '{spec.terrain}': width measured "
             f"{sv.width:.4f} m (roughness {sv.roughness.max() * 1e3:.2f} mm)")
    if not fit.feasible:
        short = {k: round(v, 4) for k, v in fit.reach_error.items() if v < -1e-3}
        what = (f"screws {sorted(short)} stop {short} m short of their walls: the brace spans about "
                f"{sv.width + 2 * min(short.values()):.3f} m" if short else
                f"a body overruns the walls by {fit.overrun * 1e3:.1f} mm: the shaft is too narrow for it")
        raise PlacementError(f"{where}: no planar brace {dict(spec.brace.screws)} of {robot.label} fits "
                             f"(bends within ±{bend_limit:.3f} rad, clearance {spec.clearance:g} m): {what}")

    model, data, S, link_of, frames, rows = sampled_robot(robot, spec.spacing)
    meta, lay = robot.metadata["screws"], robot.derived(screw_layout)
    bracing = sorted(spec.brace.screws)
    carriers = [robot.links[lay.parent_row[k]] for k in bracing]      # the screw's parent carries its load
    touching = {robot.links.index(meta[k]["link"]): k for k in bracing}
    free = ~np.isin(link_of, list(touching))
    radius = {k: float(meta[k]["radius"]) for k in bracing}
    rings = {k: 0.5 * float(meta[k]["length"]) * np.array([-1.0, 0.0, 1.0]) for k in bracing}
    # one-coordinate joints (bends, twists) take q; continuous ones (screws, (cos, sin) in Pinocchio) stay at 0
    hinge = [i for i, j in enumerate(robot.joints) if model.joints[model.getJointId(j)].nq == 1]
    iq = [model.joints[model.getJointId(robot.joints[i])].idx_q for i in hinge]
    bends = np.flatnonzero(kinds == "bend")

    # 2. the fit in the world: centre of mass onto the mid-plane point C, turned about the wall normal
    def configuration(pos, quat, q):
        c = pin.neutral(model)
        c[:3], c[3:7] = pos, quat
        c[iq] = np.asarray(q)[hinge]
        return c

    q_fit = np.asarray(fit.q, float)
    cfg = configuration(fit.pose["position"], fit.pose["quaternion"], q_fit)
    com = pin.centerOfMass(model, data, cfg).copy()
    R = Rotation.from_rotvec(spec.turn * sv.normal) * Rotation.from_matrix(sv.frame())
    anchor = np.array([com[0], 0.0, com[2]])
    p0 = sv.centre + R.apply(np.asarray(fit.pose["position"]) - anchor)
    R0 = R * Rotation.from_quat(fit.pose["quaternion"])

    # 3. what the refinement measures, for a batch of m refinement vectors X (m, 6 + bends) at once: one
    # kinematics pass per vector, then every sample and ring of the batch in one terrain query, rounded as one
    # vector at a time (batched_fd.py), so the refinement takes today's path whatever the batch
    posed = np.union1d(rows, list(touching))                  # the links whose frames are read
    posed_frames = [frames[link] for link in posed]
    screw_link = np.searchsorted(posed, [robot.links.index(meta[k]["link"]) for k in bracing])   # their columns
    screw_r = np.array([radius[k] for k in bracing])
    screw_rings = np.array([rings[k] for k in bracing])       # (b, 3) ring offsets along the axis
    k_of_material = np.array([m.k for m in terrain.materials])
    free_link, free_points = np.searchsorted(posed, link_of[free]), S.points[free]
    every_free = padded_groups(free_link, free_points, len(posed))

    def state(x, start):
        q = q_fit.copy()
        q[bends] += x[6:]
        return start + x[:3], Rotation.from_rotvec(x[3:6]) * R0, q

    def frames_of(X, start):
        """Rotations (m, L, 3, 3) and origins (m, L, 3) of the ``posed`` links' frames per vector of X."""
        quat = (Rotation.from_rotvec(X[:, 3:6]) * R0).as_quat()
        q = np.tile(q_fit, (len(X), 1))
        q[:, bends] += X[:, 6:]
        H = np.empty((len(X), len(posed), 4, 4))
        for i, x in enumerate(X):
            pin.framesForwardKinematics(model, data, configuration(start + x[:3], quat[i], q[i]))
            H[i] = [data.oMf[f].homogeneous for f in posed_frames]
        return H[..., :3, :3], H[..., :3, 3]

    def measures(X, start, samples=every_free):
        """Per vector of X (rows), in ``bracing`` order: each screw's envelope depth D (m, b), contact
        point (m, b, 3), wall normal there (m, b, 3) and wall stiffness (m, b); and the terrain's distance
        at the free samples ``samples`` (padded_groups of them; default all) (m, k)."""
        rot, org = frames_of(X, start)
        padded, slot = samples
        pts = (padded @ rot.swapaxes(-1, -2) + org[:, :, None, :]).reshape(len(X), -1, 3)[:, slot]
        a = rot[:, screw_link][..., 0]                                # the screw axes: the screw links' x
        c = org[:, screw_link, None, :] + screw_rings[None, :, :, None] * a[:, :, None, :]    # (m, b, 3, 3)
        qr = terrain.query(np.concatenate([c.reshape(-1, 3), pts.reshape(-1, 3)]))
        nc = c.size // 3
        d, n = qr.distance[:nc].reshape(c.shape[:3]), qr.normal[:nc].reshape(c.shape)
        reach = screw_r[:, None] * np.sqrt(np.clip(1.0 - (n @ a[..., None])[..., 0] ** 2, 0.0, 1.0)) - d
        deepest = np.arange(len(X))[:, None], np.arange(len(bracing)), np.argmax(reach, axis=2)   # its ring
        n_i = n[deepest]
        e = -n_i + row_dot(n_i, a)[..., None] * a                     # towards the wall, normal to the axis
        contact = c[deepest] + screw_r[:, None] * e / np.maximum(np.sqrt(row_dot(e, e)), 1e-12)[..., None]
        k_wall = k_of_material[qr.material[:nc].reshape(c.shape[:3])[deepest]]
        return reach[deepest], contact, n_i, k_wall, qr.distance[nc:].reshape(len(X), -1)

    def refine(target, x0, start):
        from scipy.optimize import least_squares

        def residuals(X, depth, dist):
            return np.concatenate([1e3 * (depth - target), 1e4 * np.maximum(spec.clearance - dist, 0.0), X[:, :3],
                                   10 * X[:, 3:6], 1e-2 * X[:, 6:]], axis=1)

        last = {}

        def fun(x):
            depth, _, _, _, dist = measures(x[None], start)
            last.update(x=x.copy(), dist=dist[0], f=residuals(x[None], depth, dist)[0])
            return last["f"]

        def jac(x):
            """Forward differences (as scipy's '2-point') from the residuals at x (the last ones evaluated:
            trf asks at the point it just accepted). A step moves a sample < 1e-6 m, so only samples within
            NEAR of the clearance there can change their term: the others' stay 0, unmeasured."""
            if not ("x" in last and np.array_equal(last["x"], x)):
                fun(x)
            f0, near = last["f"], last["dist"] < spec.clearance + NEAR

            def stepped(X):
                depth, _, _, _, d_near = measures(X, start, padded_groups(free_link[near], free_points[near],
                                                                          len(posed)))
                dist = np.full((len(X), len(near)), np.inf)
                dist[:, near] = d_near
                return residuals(X, depth, dist)

            return forward_differences(stepped, x, f0, lb, ub)

        lb = np.concatenate([np.full(6, -np.inf), lo[bends] - q_fit[bends]])
        ub = np.concatenate([np.full(6, np.inf), hi[bends] - q_fit[bends]])
        return least_squares(fun, np.clip(x0, lb + 1e-9, ub - 1e-9), bounds=(lb, ub), jac=jac, max_nfev=300).x

    def settle(start):
        """Refine at ``start`` (the tail's position before refining) and solve the pre-load, twice: the state, its
        loads and torques, and how far it misses (depth per screw beyond 0.5 mm, the worst clearance overrun)."""
        x = np.zeros(6 + len(bends))
        k_wall = measures(x[None], start)[3][0]
        target = spec.preload / len(bracing) / k_wall
        for _ in range(2):
            x = refine(target, x, start)
            depth, contact, normal, k_wall, dist = (v[0] for v in measures(x[None], start))
            pos, Rt, q = state(x, start)
            st = {"q": [float(v) for v in q],
                  "pose": {"position": [float(v) for v in pos], "quaternion": [float(v) for v in Rt.as_quat()]}}
            tau, N, mu = gravity_preload(robot, st, carriers, contact, normal, spec.preload)
            target = np.asarray(N, float) / k_wall
        miss = {k: round(float(dk - tk), 5) for k, dk, tk in zip(bracing, depth, target) if abs(dk - tk) > 5e-4}
        over = np.maximum(spec.clearance - dist, 0.0).max(initial=0.0)
        return st, dict(zip(bracing, depth.tolist())), contact, N, tau, mu, miss, float(over)

    # a rough wall (a scan) may leave no fit exactly there: the first of a few nearby spots along the wall that fits
    tried = []
    for d_long, d_up in SHIFTS:
        shift = d_long * sv.long + d_up * sv.up
        st, depth, contact, N, tau, mu, miss, over = settle(p0 + shift)
        if not miss and over <= 5e-4:
            break
        tried.append(f"({d_long:+g}, {d_up:+g}) m: depth off by {miss} m, a body {over * 1e3:.2f} mm inside")
    else:
        raise PlacementError(f"{where}: the brace fitted to the measured planes does not fit the real walls "
                             f"(clearance {spec.clearance:g} m) here or at the shifts along (long, up) tried: "
                             + "; ".join(tried))
    sign = {name: float(spec.brace.screws.get(i, 0)) for i, name in enumerate(lay.names)}
    return ShaftPlacement(q=st["q"], pose=st["pose"], survey=sv, loads={k: float(n) for k, n in zip(bracing, N)},
                          torques=[float(t) for t in tau], depth=depth, overrun=over,
                          contacts=contact, friction=mu, wall_sign=sign,
                          shift=(float(d_long), float(d_up)))
