"""Survey a shaft at a point: its narrow axis, the two walls there (points, normals, roughness), the width
and the long axis a brace rolls along; from the terrain's signed distance alone, so an analytic slot and a
mesh imported from a scan are measured the same way (issue 30, "placement in any mesh shaft").

Frames and units: world frame, z up (gravity −z), metres and radians. The free space is where the terrain's
signed distance d > 0 (terrain/base.py).

Rays. A ray p + t û (t ≥ 0) is marched by sphere tracing on the signed distance (t += d/L, L the terrain's
``lipschitz`` bound, so no step crosses the surface) until d < ``tol``, then two Newton steps
t −= d/(∇d·û) put the hit on the zero level set; a ray that goes past ``max_range`` has no hit (t = inf).

Survey at a point P (in free space)::

    narrow axis   û(θ) = (cos θ, sin θ, 0): the chord c(θ) = t₊(θ) + t₋(θ) (rays ±û from P) over a fan of
                  ``directions`` in [0, π), its least refined by a bounded scalar search: û* = û(θ*)
    centre        C = P + ½ (t₊ − t₋) û*, the chord's mid-point (P moved onto the shaft's mid-plane)
    wall patches  rays ±û* from a grid of points C + a ê_l + b ẑ, |a| ≤ ``patch_long``, |b| ≤ ``patch_height``
                  (ê_l = ẑ × û*, horizontal): each wall's hits fitted by a plane (least squares, SVD); its
                  unit normal n_w points into the free space, its RMS residual is the wall's roughness
    mean normal   n̂ = unit(n₋ − n₊) (n₋ ≈ +û*, n₊ ≈ −û*): the slot's narrow axis, tilted as the walls are
    width         w = s₊ − s₋, where the line C + s n̂ meets the two fitted planes
    long axis     ê_l = unit(n̂ × ẑ): horizontal, in the walls' plane; ê_v = ê_l × n̂ (up along the walls):
                  (ê_l, n̂, ê_v) is right-handed, a brace fit's (x, y, z) (brace_fit.py)
    tilt          per wall, asin(n_w · ẑ) (signed, + the wall faces up); the slot's lean asin(n̂ · ẑ)

The width is the plane fits' distance at C, so it averages the roughness over the patch: on a rough wall it
differs from the local width at C by up to the roughness' variation over the patch (reported as the RMS).
"""

from __future__ import annotations

import dataclasses

import numpy as np

Z = np.array([0.0, 0.0, 1.0])


class ShaftSurveyError(ValueError):
    """The point is not in a shaft the survey can measure (the message says where and why)."""


@dataclasses.dataclass(frozen=True)
class ShaftSurvey:
    """What :func:`survey_shaft` measured (world frame, z up; m, rad).

    point        (3,) the point surveyed (in free space)
    centre       (3,) the shortest chord's mid-point: on the shaft's mid-plane at the point's depth
    chord        shortest horizontal chord through ``point`` (wall to wall along ``narrow``)
    narrow       (3,) unit horizontal direction of that chord (from the − wall to the + wall)
    normal       (3,) unit mean wall normal n̂ = unit(n₋ − n₊): the narrow axis, tilted as the walls are
    long         (3,) unit horizontal axis in the walls' plane (n̂ × ẑ): along the slot, where a brace rolls
    up           (3,) unit, long × n̂: up along the walls
    width        distance between the two fitted wall planes along ``normal`` through ``centre``
    wall_points  (2, 3) the ± walls' points on the line ``centre`` + s ``normal`` (rows: − wall, + wall)
    wall_normals (2, 3) each wall's fitted plane normal, pointing into the free space (≈ +normal, −normal)
    roughness    (2,) RMS distance of each wall's patch hits from its fitted plane
    tilt         (2,) each wall's normal's elevation asin(n_w·ẑ) (0: a vertical wall)
    lean         asin(n̂·ẑ): how far the slot's narrow axis is off the horizontal
    hits         (2,) rays of each wall's patch that hit it (of patch_rays²)
    """

    point: np.ndarray
    centre: np.ndarray
    chord: float
    narrow: np.ndarray
    normal: np.ndarray
    long: np.ndarray
    up: np.ndarray
    width: float
    wall_points: np.ndarray
    wall_normals: np.ndarray
    roughness: np.ndarray
    tilt: np.ndarray
    lean: float
    hits: np.ndarray

    def frame(self) -> np.ndarray:
        """R (3×3), columns (long, normal, up): the walls' frame (a brace fit's x, y, z: brace_fit.py)."""
        return np.column_stack([self.long, self.normal, self.up])


def cast_rays(terrain, origins, directions, max_range: float = 2.0, tol: float = 1e-6,
              max_steps: int = 400) -> np.ndarray:
    """Distance t (m) along each unit direction (n, 3) from each origin (n, 3) to the terrain's surface, by
    sphere tracing on its signed distance (module docstring); inf where nothing is hit within ``max_range``
    (or the origin is not in free space)."""
    o = np.atleast_2d(np.asarray(origins, float))
    u = np.atleast_2d(np.asarray(directions, float))
    o, u = np.broadcast_arrays(o, u)
    n = len(o)
    t = np.zeros(n)
    done = np.zeros(n, bool)
    L = max(float(getattr(terrain, "lipschitz", 1.0)), 1.0)
    live = terrain.distance(o) > 0.0
    active = live.copy()
    for _ in range(max_steps):
        if not active.any():
            break
        i = np.flatnonzero(active)
        d = terrain.distance(o[i] + t[i, None] * u[i])
        hit = d < tol
        done[i[hit]] = True
        t[i[~hit]] += np.maximum(d[~hit] / L, 0.5 * tol)
        active[i[hit]] = False
        active &= t <= max_range
    i = np.flatnonzero(done)
    for _ in range(2):          # Newton on d(t) = 0 along the ray: the hit on the zero level set
        q = terrain.query(o[i] + t[i, None] * u[i])
        slope = np.einsum("ij,ij->i", q.normal, u[i])
        ok = slope < -1e-3
        t[i[ok]] -= q.distance[ok] / slope[ok]
    out = np.full(n, np.inf)
    out[done] = t[done]
    return out


def _chord(terrain, p, theta, max_range):
    u = np.stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)], axis=1)
    tp = cast_rays(terrain, np.broadcast_to(p, u.shape), u, max_range)
    tm = cast_rays(terrain, np.broadcast_to(p, u.shape), -u, max_range)
    return tp + tm, tp, tm, u


def _plane(points):
    """Least-squares plane through points (n, 3): (centroid, unit normal, RMS residual)."""
    c = points.mean(axis=0)
    _, s, vt = np.linalg.svd(points - c, full_matrices=False)
    return c, vt[2], float(s[2] / np.sqrt(len(points)))


def survey_shaft(terrain, point, directions: int = 72, patch_long: float = 0.3, patch_height: float = 0.3,
                 patch_rays: int = 7, max_range: float = 2.0, plus_side=(0.0, 1.0)) -> ShaftSurvey:
    """Survey the shaft of ``terrain`` through ``point`` (world, m; module docstring). ``directions``: the
    horizontal fan (over 180°); ``patch_long`` / ``patch_height`` (m): half-sizes of each wall's patch along
    the long axis and up the wall (the span a brace covers); ``patch_rays``: rays per side of that grid;
    ``max_range`` (m): rays longer than this count as no wall (the shaft is wider there); ``plus_side``: a
    horizontal (x, y) direction, the narrow axis is oriented along it (û*·plus_side ≥ 0: which wall is +)."""
    from scipy.optimize import minimize_scalar

    P = np.asarray(point, float).reshape(3)
    d0 = float(terrain.distance(P[None])[0])
    if not d0 > 0.0:
        raise ShaftSurveyError(f"shaft survey at {np.round(P, 4).tolist()}: the point is {-d0:.4g} m inside the "
                               "terrain's solid, not in the shaft's free space: give a point inside the shaft")
    theta = np.arange(directions) * np.pi / directions
    c, _, _, _ = _chord(terrain, P, theta, max_range)
    if not np.isfinite(c).any():
        raise ShaftSurveyError(f"shaft survey at {np.round(P, 4).tolist()}: no horizontal chord meets walls on "
                               f"both sides within max_range {max_range:g} m: not a shaft here")
    k = int(np.argmin(c))
    step = np.pi / directions
    res = minimize_scalar(lambda th: float(_chord(terrain, P, np.array([th]), max_range)[0][0]),
                          bounds=(theta[k] - step, theta[k] + step), method="bounded", options={"xatol": 1e-6})
    th = res.x if res.fun <= c[k] else theta[k]
    chord, tp, tm, u = _chord(terrain, P, np.array([th]), max_range)
    u = u[0]
    if u[:2] @ np.asarray(plus_side, float) < 0.0:
        u, tp, tm = -u, tm, tp
    centre = P + 0.5 * (tp[0] - tm[0]) * u
    el = np.cross(Z, u)
    a, b = np.meshgrid(np.linspace(-patch_long, patch_long, patch_rays),
                       np.linspace(-patch_height, patch_height, patch_rays), indexing="ij")
    origins = centre + a.reshape(-1, 1) * el + b.reshape(-1, 1) * Z
    planes, hits = [], []
    for sign in (-1.0, 1.0):                      # the − wall (rays −û*), then the + wall
        t = cast_rays(terrain, origins, np.broadcast_to(sign * u, origins.shape), max_range)
        ok = np.isfinite(t)
        hits.append(int(ok.sum()))
        if ok.sum() < 3:
            raise ShaftSurveyError(f"shaft survey at {np.round(P, 4).tolist()}: only {ok.sum()} of the "
                                   f"{len(t)} patch rays towards the {'+' if sign > 0 else '−'} wall hit it: "
                                   "make the patch smaller (patch_long, patch_height) or survey elsewhere")
        pc, n, rms = _plane(origins[ok] + t[ok, None] * sign * u)
        n = n if n @ (-sign * u) > 0 else -n      # into the free space: towards the centre
        planes.append((pc, n, rms))
    (cm, nm, rm), (cp, npl, rp) = planes
    normal = nm - npl
    normal /= np.linalg.norm(normal)
    s = [float((pc - centre) @ n / (normal @ n)) for pc, n, _ in planes]
    long = np.cross(normal, Z)
    long /= np.linalg.norm(long)
    up = np.cross(long, normal)
    return ShaftSurvey(point=P, centre=centre, chord=float(chord[0]), narrow=u, normal=normal, long=long, up=up,
                       width=s[1] - s[0], wall_points=np.array([centre + s[0] * normal, centre + s[1] * normal]),
                       wall_normals=np.array([nm, npl]), roughness=np.array([rm, rp]),
                       tilt=np.arcsin(np.clip([nm @ Z, npl @ Z], -1, 1)), lean=float(np.arcsin(normal @ Z)),
                       hits=np.array(hits))
