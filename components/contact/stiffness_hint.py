"""The penalty contact's stiffest mode for the step check (``Component.stiffness_hint``).

A body of mass m pressed by n contact points of stiffness k and damping c oscillates at
ω = sqrt(n·k/m) and its damping decays at n·c/m: the lightest contacting body and the stiffest
material of the terrain (with the component's ``material`` override) give the largest of both.
"""

from __future__ import annotations

import math

from snakesim.components.materials import material_table


def penalty_modes(comp, u, rows_points, what: str) -> list[tuple[float, str]]:
    """``rows_points``: (link row, contact points it may have at once) per contacting body."""
    try:
        terrain = u.terrain
    except Exception:           # not computed before the first step: nothing to estimate from
        return []
    if terrain is None or not getattr(terrain, "materials", None):
        return []
    p = comp.p
    table = material_table(terrain.materials, p.material, fn_max=p.fn_max, ev_floor=p.ev_floor, owner=comp.name)
    k, c = float(table[:, 0].max()), float(table[:, 1].max())
    tree, links = comp.robot.tree, comp.robot.links
    best = None
    for row, n in rows_points:
        m = float(tree.links[tree.link_index[links[row]]].mass)
        if m > 0 and (best is None or n / m > best[1] / best[2]):
            best = (links[row], n, m)
    if best is None:
        return []
    link, n, m = best
    return [(math.sqrt(n * k / m), f"contact stiffness k = {k:g} N/m x {n} {what} on link '{link}' of mass {m:.3g} kg"),
            (n * c / m, f"contact damping c = {c:g} N*s/m x {n} {what} on link '{link}' of mass {m:.3g} kg")]
