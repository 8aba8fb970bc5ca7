"""``--terrain`` on a scene: the robot put on the new terrain, or a refusal that says why.

A scene places its robot for its own terrain (``base_position`` of its multibody): the default scene's
screws just press flat ice at z = 0. Given another terrain (``--terrain fractal-dem``) that base may lie
inside the new surface (the DEM rises 15 cm) or above it. One rule for every terrain kind: when the robot
starts inside the new terrain (deeper than ``INSIDE_TOL``) it is seated on the terrain's local surface
under it, in three steps of the base (joint angles as the scene has them):

1. tilt: the plane fitted to the terrain's surface under the robot's collision points (each point
   taken to the surface along the SDF gradient, s_i = p_i − φ(p_i) n̂(p_i), a few times; least squares
   z = a x + b y + c) has the normal n̂ = unit(−a, −b, 1). The scene placed the robot for gravity's
   "down", −ẑ; the base is turned by the shortest rotation R taking ẑ to n̂, about the points' centroid
   o (p → o + R (p − o)), so the body's "down" is −n̂: every screw that lay on flat ice now lies on
   the slope.
2. rest: on a rough surface the fitted plane leaves some screws hanging, and the robot would rock onto
   them. The base is turned further, about o and with no yaw, to the rigid body's rest of least potential
   energy: o as low as it goes with no collision point inside the terrain (o stands for the centre of
   mass: the centroid of the collision samples, a uniform snake's). A linear program per step, on the
   gaps linearised in the small turn ω = (ω_x, ω_y, 0) and rise dz::

    minimise dz   subject to   φ_i + n̂_i · (ω × (p_i − o)) + n̂_i,z dz ≥ 0   for every sample i,
                               |ω_x|, |ω_y| ≤ ``REST_TURN``, |dz| ≤ ``REST_RISE`` (the step's trust region)

   repeated (``REST_STEPS`` at most) until the step turns less than ``MIN_TILT`` / 100. On a plane the fitted
   turn is already that rest; on a DEM it rocks the robot onto its supports around o (three, or a line).
   A total turn (1 and 2) below ``MIN_TILT`` is not made: the orientation stays the scene's, to the bit.
3. lift: the base moved along world z by the ``dz`` at which the lowest of the robot's collision points
   touches the terrain::

    g(dz) = min_i φ(p_i + dz ẑ)      p_i every <collision> shape's samples (screw envelopes included)
                                     at the scene's initial state (turned), φ the terrain's signed distance
    dz:     g(dz) = 0, by Newton steps dz ← dz − g / n̂_z (n̂ the normal at the minimising point)

so the robot rests on the terrain's local height under it (|g| ≤ ``TOUCH_TOL``, the flat scene's own
0.2 mm pre-press), and on a plane every screw does: the run starts with no drop (tests/placement/
test_terrain_swap.py measures each screw's gap and the first 0.3 s); on a DEM the supports of step 2 do.
Where no such ``dz`` exists within ``MAX_SHIFT`` (the surface above the robot faces down, an enclosing
kind has no floor under it, the search does not settle), the run is refused, naming the terrain and the
reason.

Registered as the ``apply`` of ``--terrain`` (components/plugin.py ``snakesim_run_options``; the option
itself is the shorthand ``--set terrain=...``): it builds the scene's plan once (no warm-up) to read the
initial link poses and the terrain, and writes the new ``base_position`` (and ``base_quaternion``, when
turned) into the resolved configuration,
so the run, ``config.yaml`` and ``check`` all see the placed robot.
"""

from __future__ import annotations

import numpy as np

from snakesim.framework.errors import SnakesimError

#: m, the most the base is moved up or down
MAX_SHIFT = 5.0
#: m, |g| accepted as touching
TOUCH_TOL = 2.0e-4
#: m, spacing of the collision samples (a cylinder's lowest line is missed by at most r (1 − cos(π/n)))
SPACING = 0.01
#: the moves below this are not written (the scene's own placement kept)
MIN_MOVE = 1.0e-4
#: m, a robot whose collision points are all at most this deep in the new terrain is left where the scene
#: (or the user's base_position) puts it: above the terrain it drops onto it, as a scene's drop does, and a
#: brace's pre-load (a few mm into the walls) is not a placement to undo
INSIDE_TOL = 5.0e-3
#: rad, a fitted surface tilted less than this leaves the scene's orientation as it is (a flat terrain's fit
#: is ẑ to rounding; 1 mrad tilts a 4 m robot's ends by 2 mm, within a screw's pre-press and the touch tol.)
MIN_TILT = 1.0e-3
#: projections of the collision points onto the surface for the plane fit (one is exact for a plane's SDF,
#: a DEM's first-order SDF converges in two or three)
SURFACE_STEPS = 3
#: rad and m, the trust region of one rest step (module docstring, step 2): a linearised gap is off by
#: |p − o| · REST_TURN² / 2 ≈ 1 mm at 2 m from o, which the next step corrects
REST_TURN = 0.03
REST_RISE = 0.05
#: rest steps at most (a DEM settles in 3 or 4)
REST_STEPS = 20


class TerrainPlacementError(SnakesimError):
    """The robot cannot be put on the terrain by a vertical move."""


def vertical_rest_shift(points: np.ndarray, terrain, max_shift: float = MAX_SHIFT,
                        iterations: int = 60) -> float:
    """The ``dz`` at which the lowest of ``points`` (n, 3, world) touches ``terrain`` (module docstring);
    raises :class:`TerrainPlacementError` where there is none."""
    P = np.asarray(points, dtype=float)
    name = getattr(terrain, "name", "the terrain")
    dz = 0.0
    for _ in range(iterations):
        q = terrain.query(P + np.array([0.0, 0.0, dz]))
        i = int(np.argmin(q.distance))
        g, nz = float(q.distance[i]), float(q.normal[i, 2])
        if abs(g) <= TOUCH_TOL:
            return dz
        if nz <= 0.1:
            where = "under" if g < 0 else "nearest to"
            raise TerrainPlacementError(
                f"--terrain {name}: cannot place the robot on it: the surface {where} its lowest collision point "
                f"(at {np.round(P[i] + [0, 0, dz], 3).tolist()} m, {-g * 1e3:.0f} mm {'inside' if g < 0 else 'away'}) "
                f"does not face up (normal z = {nz:.2f}), so no vertical move rests it there; choose a scene made "
                "for this terrain or set components.<robot>.params.base_position yourself")
        dz -= g / max(nz, 0.2)
        if abs(dz) > max_shift:
            raise TerrainPlacementError(
                f"--terrain {name}: cannot place the robot on it: its surface is more than {max_shift:g} m above or "
                "below the robot's starting place; choose a scene made for this terrain or set "
                "components.<robot>.params.base_position yourself")
    raise TerrainPlacementError(
        f"--terrain {name}: cannot place the robot on it: the lowest collision point found no resting height "
        f"in {iterations} steps (last {g * 1e3:.1f} mm off); set components.<robot>.params.base_position yourself")


def surface_normal(points: np.ndarray, terrain) -> np.ndarray | None:
    """n̂ of the plane fitted to ``terrain``'s surface under ``points`` (n, 3, world): module docstring,
    step 1. None where that surface is no height field (most of it faces sideways or down: a wall, a
    tube's roof), which no plane of heights fits: the robot is then only lifted (step 3), or refused."""
    s = np.array(points, dtype=float)
    for _ in range(SURFACE_STEPS):
        q = terrain.query(s)
        s -= q.distance[:, None] * q.normal
    if float(np.median(q.normal[:, 2])) <= 0.1:
        return None
    A = np.column_stack([s[:, 0], s[:, 1], np.ones(len(s))])
    (a, b, _), *_ = np.linalg.lstsq(A, s[:, 2], rcond=None)
    n = np.array([-a, -b, 1.0])
    return n / np.linalg.norm(n)


def tilt_to(normal: np.ndarray):
    """The shortest rotation taking ẑ to ``normal`` (a scipy Rotation), and its angle, rad."""
    from scipy.spatial.transform import Rotation

    n = np.asarray(normal, dtype=float)
    axis = np.cross([0.0, 0.0, 1.0], n)
    angle = float(np.arctan2(np.linalg.norm(axis), n[2]))
    if angle == 0.0:
        return Rotation.identity(), 0.0
    return Rotation.from_rotvec(axis / np.linalg.norm(axis) * angle), angle


def rest_turn(points: np.ndarray, terrain, o: np.ndarray):
    """The turn about ``o`` (a scipy Rotation, no yaw) that rests the rigid ``points`` (n, 3, world) on
    ``terrain`` with ``o`` lowest: module docstring, step 2. The rise is left to :func:`vertical_rest_shift`."""
    from scipy.optimize import linprog
    from scipy.spatial.transform import Rotation

    P = np.array(points, dtype=float)
    o = np.array(o, dtype=float)
    total = Rotation.identity()
    bounds = [(-REST_RISE, REST_RISE), (-REST_TURN, REST_TURN), (-REST_TURN, REST_TURN)]
    for _ in range(REST_STEPS):
        q = terrain.query(P)
        lever = np.cross(P - o, q.normal)            # n̂ · (ω × r) = ω · (r × n̂)
        A = -np.column_stack([q.normal[:, 2], lever[:, 0], lever[:, 1]])
        res = linprog([1.0, 0.0, 0.0], A_ub=A, b_ub=q.distance, bounds=bounds, method="highs")
        if res.status != 0:
            break               # no small move keeps every point out (a concave pocket): step 3 alone
        dz, wx, wy = res.x
        step = Rotation.from_rotvec([wx, wy, 0.0])
        P = o + step.apply(P - o) + [0.0, 0.0, dz]
        o = o + [0.0, 0.0, dz]
        total = step * total
        if max(abs(wx), abs(wy)) < MIN_TILT / 100:
            break
    return total


def base_quaternion(p) -> np.ndarray:
    """The multibody's initial base orientation (x, y, z, w) from its Params, as joint_values.initial_state
    reads them (``base_quaternion``, else ``base_yaw``)."""
    if p.base_quaternion is not None:
        q = np.array(p.base_quaternion, dtype=float)
        return q / np.linalg.norm(q)
    return np.array([0.0, 0.0, np.sin(p.base_yaw / 2), np.cos(p.base_yaw / 2)])


def collision_points(robot, poses: np.ndarray) -> np.ndarray:
    """Every <collision> shape's samples (screws included) in the world, at link ``poses`` (nl, 7)."""
    from snakesim.components.contact.body_samples import BodySampleOptions, body_samples
    from snakesim.components.multibody.pose_quaternions import rotation_matrices

    s = robot.derived(body_samples, BodySampleOptions(spacing=SPACING, exclude_screws=False))
    link = np.repeat(s.piece_link, np.diff(s.start)).astype(np.int64)
    R = rotation_matrices(np.ascontiguousarray(poses[link, 3:]))
    return poses[link, :3] + np.einsum("nij,nj->ni", R, s.points)


def place_on_terrain(resolved, value) -> list[tuple[str, float, float]]:
    """``apply`` of ``--terrain``: every multibody with a ``base_position`` seated on the scene's terrain
    (module docstring). Returns ``(component, dz, tilt)`` for each one moved: the base's rise along z, m
    (after the turn), and the turn, rad."""
    from scipy.spatial.transform import Rotation

    from snakesim.components.multibody.robot_model import RobotModel
    from snakesim.framework.builder import Builder
    from snakesim.framework.registry import default_registry

    movable = [n for n, spec in resolved.components.items() if "base_position" in (spec.params or {})]
    if not movable:
        return []
    plan = Builder.from_resolved(resolved, default_registry()).plan()
    terrains = [c for c in plan.components.values() if getattr(c, "type_name", "") == "terrain"]
    robots = [n for n in movable if n in plan.components
              and isinstance(getattr(plan.components[n], "robot", None), RobotModel)]
    if len(terrains) != 1 or not robots:
        return []          # no terrain (or several) the robot stands on: nothing to place
    t0 = resolved.sim.t0
    for fn, x, u, y in plan.once:
        fn(t0, x, u, y)
    plan.f(t0, plan.X)      # the outputs at the initial state: link poses, the terrain
    terrain = plan.io[terrains[0].name][2].terrain
    moved = []
    for name in robots:
        comp = plan.components[name]
        poses = np.asarray(plan.io[name][2].link_poses, dtype=float)
        pts = collision_points(comp.robot, poses)
        if float(terrain.distance(pts).min()) >= -INSIDE_TOL:
            continue        # clear of the terrain (or pressing it as a brace does): the scene's placement stands
        base = np.array(comp.p.base_position, dtype=float)
        o = pts.mean(axis=0)
        normal = surface_normal(pts, terrain)
        tilt = 0.0
        if normal is not None:
            turn, _ = tilt_to(normal)
            tilted = o + turn.apply(pts - o)
            rise = np.array([0.0, 0.0, vertical_rest_shift(tilted, terrain)])  # touching: a small move rests it
            turn = rest_turn(tilted + rise, terrain, o + rise) * turn
            tilt = float(turn.magnitude())
        params = resolved.components[name].params
        if tilt >= MIN_TILT:
            pts = o + turn.apply(pts - o)
            base = o + turn.apply(base - o)
            quat = (turn * Rotation.from_quat(base_quaternion(comp.p))).as_quat()
            params["base_quaternion"] = [float(v) for v in quat]
        else:
            tilt = 0.0
        dz = vertical_rest_shift(pts, terrain)
        if abs(dz) < MIN_MOVE and tilt == 0.0:
            continue
        base[2] += dz
        params["base_position"] = [float(v) for v in base]
        moved.append((name, dz, tilt))
    return moved


def apply_terrain_option(resolved, value) -> None:
    """The ``--terrain`` option's ``apply``: place, and say so in one line."""
    import click

    for name, dz, tilt in place_on_terrain(resolved, value):
        turned = f", turned {np.degrees(tilt):.1f} deg to rest on the surface's slope under it" if tilt else ""
        click.echo(f"--terrain {value}: {name} placed on it (base {'raised' if dz > 0 else 'lowered'} "
                   f"{abs(dz) * 1e3:.0f} mm{turned}: its lowest collision point on the terrain's height under it)",
                   err=True)


apply_terrain_option.for_check = True
