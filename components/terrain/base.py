"""The terrain query interface shared by every kind.

    q = terrain.query(points)        # points (n, 3) m, world frame
    q.distance  (n,)   m   signed, > 0 outside the solid (in free space), < 0 = penetration
    q.normal    (n, 3)     unit, pointing out of the solid (towards free space)
    q.closest   (n, 3) m   closest surface point, = points - distance * normal
    q.material  (n,)       index into terrain.materials (per region; Material: snakesim.components.materials)

Analytic kinds are exact where the geometry allows (plane, walls, smooth tube,
U-channel); rough surfaces and height fields use a first-order distance
(documented per kind) whose gradient equals the returned normal on the surface.

A kind is one Terrain subclass plus its registration (terrain/kinds.py: the ``kind:`` name,
the spec model, the factory). Everything a consumer needs is a method here, with a default,
so a new kind implements :meth:`Terrain._query` and only overrides what it does better:

    display_mesh(center, extent, cell, cutaway)   the viewer's mesh; also the sensors' Embree
        scene (cutaway None). Default: the zero level set as a surface net (display.level_set_mesh)
    sensor_cell(extent, cell)                     the tessellation the sensors ask for (flat kinds:
        a few large quads). Default: ``cell``
    refine_hits                                   whether a ray's mesh hit on a face that is off the
        surface is refined onto the zero level set (False where the mesh *is* the surface: an
        imported mesh). Default True: Newton on :meth:`query` along the ray
    refine_every_face                             refine on every face, not only those off the surface
        (a DEM: its bilinear cells leave their triangles). Default False
    refiner(vertices, margin)                     a compiled refinement (tube, moulin: numba), or None
        for the generic Newton iteration. Default None
    contact_parts(extent, segments, resolution)   the hull back end's geometry: HalfSpace and
        Triangles records. Default: the triangles of display_mesh around the origin
    fast_plane()                                  (origin, normal) where the SDF contact may query the
        terrain as one plane in numba. Default None
    parts(points), part_count                     which separate object (an obstacle) each surface point
        belongs to, -1 for the kind's continuous surface: sensors label part i as its own object
        (perception/labels.py). Default None, 0: no parts

Static geometry and state
-------------------------
A Terrain object is built once per run (TerrainSource.setup) and is the same object every step.
What a run can change lives in ``terrain.state`` (:class:`TerrainState`), never in the geometry
built in ``__init__``:

- the static geometry (parameters, tables, grids, compiled records) is fixed once the object is
  built: consumers may pack it, mesh it and bind it;
- ``state`` holds named arrays that a kind's own model (a deformable terrain, the next issues) changes
  **in place** during a run (``state.x[...] = ...``, never ``state.x = new_array``), then calls
  ``state.changed()``, which bumps ``state.version``; ``query`` reads the state arrays at every call;
- consumers that pack or bind terrain data (the contact components' ``use_terrain``) rebind only
  when the terrain *object* changes (``is not``), never because its state changed: a compiled kernel
  bound to a state array sees the new values through the same buffer;
- consumers that *derive* geometry from the terrain once and keep it (the sensors' Embree scene, the
  viewer's mesh, a placement's nearest points; the hull back end's parts are the contact's to move
  onto it) rebuild it when ``state.version`` differs from the version they built from, and only
  then: one rule, :class:`~.derived.TerrainDerived` (terrain/derived.py), held per run.

The built-in kinds are static: their state is empty and its version stays 0.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from snakesim.components.materials import Material   # re-exported: the terrain's materials are these


@dataclasses.dataclass(frozen=True)
class TerrainQuery:
    """Result of :meth:`Terrain.query` for n points (arrays, SI units)."""

    distance: np.ndarray
    normal: np.ndarray
    closest: np.ndarray
    material: np.ndarray

    def __len__(self) -> int:
        return int(self.distance.shape[0])


@dataclasses.dataclass(frozen=True)
class TerrainMesh:
    """vertices (n, 3) m, faces (m, 3), normals (n, 3), colors (n, 4) uint8; world frame."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    colors: np.ndarray


@dataclasses.dataclass(frozen=True)
class HalfSpace:
    """The solid {x: normal·x ≤ offset} (normal unit, pointing out of the solid): an exact contact part."""

    normal: np.ndarray
    offset: float


@dataclasses.dataclass(frozen=True)
class Triangles:
    """A triangulated surface part: vertices (n, 3) m world, faces (m, 3) int. Triangles have no
    inside: consumers orient contact normals with the terrain's query."""

    vertices: np.ndarray
    faces: np.ndarray


class TerrainState:
    """A terrain's mutable state: named arrays changed in place during a run (module docstring).

        state = TerrainState(heights=np.zeros((n, m)))
        state.heights[i, j] -= dz      # in place: every bound buffer sees it
        state.changed(t)               # version + 1, at simulated time t s: consumers that derive notice

    ``version`` counts the changes (0: as built). The rule for consumers: what binds a state array
    (a compiled kernel) sees a change through the same buffer and never rebinds for it; what derives
    geometry from the terrain once and keeps it (the sensors' Embree scene, the viewer's mesh) keeps
    it in a :class:`~.derived.TerrainDerived`, which rebuilds when ``version`` differs from the one it
    built from, and only then (a static kind: never). ``changed_at`` is the simulated time (s) of the
    last change when the model gave it (the viewer logs the new mesh there), else None.

    An empty state (the static kinds) has no arrays and version 0; ``may_change`` is False for it, so
    the viewer logs its mesh once, static.
    """

    def __init__(self, **arrays):
        self.version = 0
        self.changed_at: float | None = None
        self.names: tuple[str, ...] = tuple(arrays)
        for name, value in arrays.items():
            setattr(self, name, np.asarray(value))

    def changed(self, t: float | None = None) -> None:
        """Say the arrays were changed (in place), at simulated time ``t`` s if known; bumps ``version``."""
        self.changed_at = None if t is None else float(t)
        self.version += 1

    @property
    def may_change(self) -> bool:
        """Whether a run can change this state: it has arrays (a static kind's has none)."""
        return bool(self.names)

    def arrays(self) -> dict[str, np.ndarray]:
        return {name: getattr(self, name) for name in self.names}

    def __repr__(self) -> str:
        shapes = ", ".join(f"{n}{tuple(getattr(self, n).shape)}" for n in self.names)
        return f"TerrainState({shapes}; version {self.version})"


@dataclasses.dataclass(frozen=True)
class Bounds:
    """Axis-aligned box (m); ±inf where the terrain is unbounded."""

    lo: np.ndarray
    hi: np.ndarray


def as_points(points) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim == 1 and p.shape[0] == 3:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"terrain query expects points of shape (n, 3), got {np.shape(points)}")
    return p


def unit(v: np.ndarray, fallback=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Row-normalise v (n, 3); rows of zero length become ``fallback``."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    out = np.where(n > 1e-300, v / np.where(n > 1e-300, n, 1.0), np.asarray(fallback, dtype=float))
    return out


def frame_from_axis(axis) -> np.ndarray:
    """Rotation R (3x3) whose third column is ``axis`` (unit): local -> world is R @ x_local."""
    a = np.asarray(axis, dtype=float)
    n = np.linalg.norm(a) if a.shape == (3,) else 0.0
    if not (np.isfinite(n) and n > 1e-12):
        raise ValueError(f"axis = {a.tolist()}: needs a finite, non-zero 3-vector")
    a = a / n
    ref = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(ref, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    return np.column_stack([e1, e2, a])


class Terrain:
    """Base class. Subclasses implement :meth:`_query` on validated (n, 3) points.

    ``materials`` lists the materials; ``regions`` names the surface regions of
    the kind (e.g. floor, walls) and ``region_material[i]`` the material index
    of region i, so ``query().material`` is ``region_material[region_of_point]``.
    """

    kind: str = "terrain"
    regions: tuple[str, ...] = ("surface",)
    #: refine a ray's hits on mesh faces off the surface onto the zero level set (module docstring)
    refine_hits: bool = True
    #: refine hits on every face, not only on faces whose centre is off the surface: a height field's
    #: bilinear patches leave their two triangles everywhere but at the grid's vertices (terrain/dem.py)
    refine_every_face: bool = False

    def __init__(self, materials=(Material(),), region_material=None, name: str = "", state=None):
        self.materials: tuple[Material, ...] = tuple(materials)
        if not self.materials:
            raise ValueError("a terrain needs at least one material")
        rm = np.zeros(len(self.regions), dtype=np.int64) if region_material is None else \
            np.asarray(region_material, dtype=np.int64)
        if rm.shape != (len(self.regions),) or rm.min() < 0 or rm.max() >= len(self.materials):
            raise ValueError(f"region_material must map {len(self.regions)} regions {self.regions} "
                             f"to indices < {len(self.materials)}, got {rm.tolist()}")
        self.region_material = rm
        self.name = name or self.kind
        #: what a run may change, in place (module docstring); static kinds: empty
        self.state: TerrainState = TerrainState() if state is None else state

    # -- the interface --------------------------------------------------------
    def query(self, points) -> TerrainQuery:
        """Signed distance, outward normal, closest point and material of each point."""
        p = as_points(points)
        d, n, region = self._query(p)
        return TerrainQuery(distance=d, normal=n, closest=p - d[:, None] * n,
                            material=self.region_material[region])

    def distance(self, points) -> np.ndarray:
        """Signed distance only (m)."""
        return self.query(points).distance

    def bounds(self) -> Bounds:
        """Axis-aligned box containing the terrain surface (inf where unbounded)."""
        return Bounds(np.full(3, -np.inf), np.full(3, np.inf))

    def distance_lower_bound(self, centers, radii) -> np.ndarray:
        """Broad phase: per sphere, a value <= the least signed distance of any point in it.

        A sphere whose bound is > 0 cannot touch the solid and can be skipped.
        Uses the Lipschitz bound of the returned distance field: d(c) − L·r,
        with L = ``self.lipschitz`` (1 for exact distance fields; for the
        first-order kinds, rough cylinders and DEMs, an estimate from the
        largest wall slope).
        """
        c = as_points(centers)
        r = np.broadcast_to(np.asarray(radii, dtype=float), (c.shape[0],))
        return self.query(c).distance - self.lipschitz * r

    #: upper bound of |∇distance| (1 for exact distance fields)
    lipschitz: float = 1.0

    def _query(self, p: np.ndarray):
        """-> distance (n,), unit normal (n, 3), region index (n,) int."""
        raise NotImplementedError

    # -- what consumers ask of a kind (defaults: from the query alone) ------------------
    def display_mesh(self, center: np.ndarray, extent: float, cell: float, cutaway: np.ndarray | None) -> TerrainMesh:
        """The surface as triangles, ``extent`` m around ``center`` where unbounded, at about ``cell`` m;
        ``cutaway`` (unit, or None) the side an enclosing kind may leave open towards the viewer.
        Drawn from the state as it is now (consumers that keep it redraw it when ``state.version``
        moves: terrain/derived.py). Default: the zero level set of :meth:`query` (display.level_set_mesh;
        no cut-away)."""
        from .display import level_set_mesh

        return level_set_mesh(self, center, extent, cell)

    def sensor_cell(self, extent: float, cell: float) -> float:
        """The ``cell`` the sensors' mesh is built at, asked for ``cell`` over ``extent`` (flat kinds
        tessellate exactly with a few large quads)."""
        return cell

    def refiner(self, vertices=None, margin: float = 1.0):
        """A compiled refinement of ray hits (perception/refine_kernels.py: ``refine``,
        ``beyond_wall``, ``query``) for the sensor mesh ``vertices``, or None: the generic Newton
        iteration on :meth:`query`."""
        return None

    def contact_parts(self, extent: float = 10.0, segments: int = 64, resolution: float = 0.05) -> list:
        """The hull back end's geometry: :class:`HalfSpace` and :class:`Triangles` records. Default:
        the display mesh's triangles, ``extent`` m around the origin at ``resolution`` m.
        NotImplementedError: the kind has none (the hull back end says so)."""
        m = self.display_mesh(np.zeros(3), extent, resolution, None)
        return [Triangles(np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64))]

    #: how many parts :meth:`parts` tells apart (0: none)
    part_count: int = 0

    def parts(self, points) -> np.ndarray | None:
        """(n,) int64: the part (0 … part_count − 1) each surface point (n, 3) m, world, belongs to, −1 on
        the kind's continuous surface; None for a kind without parts (the default)."""
        return None

    def height_grid(self, lo, hi):
        """The surface as a height field z = h(x, y) covering at least the box ``lo``…``hi`` ((x, y), m,
        world): (z (rows y, columns x) m, spacing m, (x0, y0) of z[0, 0] m), read bilinearly with its edge
        values extended flat (terrain/dem.py's convention). What a deformable soil is laid on
        (terrain/deformable.py's ``base``); None for a kind that is not a height field (the default)."""
        return None

    def fast_plane(self):
        """(origin, unit normal) when the whole terrain is that one plane and its query may be replaced
        by the compiled plane kernels of the SDF contact; None otherwise."""
        return None

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r}>"
