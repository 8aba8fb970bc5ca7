"""``--terrain`` on a scene: the robot put on the new terrain, or a refusal that says why.

A scene places its robot for its own terrain (``base_position`` of its multibody): the default scene's
screws just press flat ice at z = 0. Given another terrain (``--terrain fractal-dem``) that base may lie
inside the new surface (the DEM rises 15 cm) or above it. One rule for every terrain kind: the base is
moved along world z only (orientation, joint angles and x, y as the scene has them) when it starts
inside the new terrain (deeper than ``INSIDE_TOL``), by the ``dz`` at which the lowest of the robot's
collision points touches the terrain::

    g(dz) = min_i φ(p_i + dz ẑ)      p_i every <collision> shape's samples (screw envelopes included)
                                     at the scene's initial state, φ the terrain's signed distance
    dz:     g(dz) = 0, by Newton steps dz ← dz − g / n̂_z (n̂ the normal at the minimising point)

so the robot rests on the terrain's local height under it. Where no such ``dz`` exists within
``MAX_SHIFT`` (the surface above the robot faces down, an enclosing kind has no floor under it, the
search does not settle), the run is refused, naming the terrain and the reason.

Registered as the ``apply`` of ``--terrain`` (components/plugin.py ``snakesim_run_options``; the option
itself is the shorthand ``--set terrain=...``): it builds the scene's plan once (no warm-up) to read the
initial link poses and the terrain, and writes the new ``base_position`` into the resolved configuration,
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


def collision_points(robot, poses: np.ndarray) -> np.ndarray:
    """Every <collision> shape's samples (screws included) in the world, at link ``poses`` (nl, 7)."""
    from snakesim.components.contact.body_samples import BodySampleOptions, body_samples
    from snakesim.components.multibody.pose_quaternions import rotation_matrices

    s = robot.derived(body_samples, BodySampleOptions(spacing=SPACING, exclude_screws=False))
    link = np.repeat(s.piece_link, np.diff(s.start)).astype(np.int64)
    R = rotation_matrices(np.ascontiguousarray(poses[link, 3:]))
    return poses[link, :3] + np.einsum("nij,nj->ni", R, s.points)


def place_on_terrain(resolved, value) -> list[tuple[str, float]]:
    """``apply`` of ``--terrain``: every multibody with a ``base_position`` moved onto the scene's terrain
    (module docstring). Returns ``(component, dz)`` for each one moved."""
    from snakesim.framework.builder import Builder
    from snakesim.framework.registry import default_registry

    from snakesim.components.multibody.robot_model import RobotModel

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
        dz = vertical_rest_shift(pts, terrain)
        if abs(dz) < MIN_MOVE:
            continue
        base = [float(v) for v in comp.p.base_position]
        base[2] += dz
        resolved.components[name].params["base_position"] = base
        moved.append((name, dz))
    return moved


def apply_terrain_option(resolved, value) -> None:
    """The ``--terrain`` option's ``apply``: place, and say so in one line."""
    import click

    for name, dz in place_on_terrain(resolved, value):
        click.echo(f"--terrain {value}: {name} placed on it (base {'raised' if dz > 0 else 'lowered'} "
                   f"{abs(dz) * 1e3:.0f} mm: its lowest collision point on the terrain's height under it)", err=True)


apply_terrain_option.for_check = True
