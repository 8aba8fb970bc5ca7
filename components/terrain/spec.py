"""YAML terrain definitions: pydantic schema (``kind:`` discriminator) and :func:`load_terrain`.

    kind: u_channel            # plane | dem | tube | parallel_walls | u_channel | moulin | obstacles | mesh,
                               # or a kind a plugin registers (terrain/kinds.py)
    width: 0.4
    materials:                 # first one is the default of every region
      - {name: ice, k: 2.0e5, c: 500, mu: 0.1}
      - {name: rock, k: 1.0e6, c: 2000, mu: 0.6}
      - {include: hard-ice.yaml}   # the materials of a materials file, here
    regions: {floor: rock}     # region -> material name (regions per kind: see each class)

Materials are snakesim.components.materials.Material (k N/m, c N·s/m, mu, ev_a, ev_b 1/N).
A materials file (what ``snakesim fit-friction --out`` writes) has one key, ``materials:``,
a list in the same form; ``{include: FILE}`` puts its materials where the entry stands.

An obstacle field (flat ground with blocks and rocks, regions ground | blocks | rocks):

    kind: obstacles
    ground_height: 0.0
    boxes:   [{center: [2, 0.8, 0.15], size: [0.4, 0.3, 0.3], yaw: 0.3}]     # full edges; roll, pitch too
    spheres: [{center: [3, -0.9, -0.05], radius: 0.2}]                       # centre below ground: a boulder
    random:  {count: 20, seed: 1, area: [1, 8, -2, 2], size: [0.2, 0.5], kinds: [box, sphere],
              keep_clear: {center: [0, 0], radius: 1.0}}                     # + burial, min_gap

Files named in a definition (DEM grids, meshes, material files) are relative to the YAML file.
"""

from __future__ import annotations

import difflib
from importlib.resources import files
from pathlib import Path
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError, field_validator, model_validator

from snakesim.components.materials import Material, material_from_mapping, read_material_file
from snakesim.framework import ConfigError
from snakesim.framework.validation_errors import config_error, where_in
from snakesim.framework.yaml_source import load_yaml

from . import analytic, dem, mesh, obstacles
from .base import Terrain

Vec3 = tuple[float, float, float]


class _Model(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)   # every number finite


class _Base(_Model):
    description: str = ""
    materials: list[Material] = Field(default_factory=lambda: [Material()], min_length=1,
                                      description="first = default of every region; {include: FILE} entries "
                                                  "are expanded before validation")
    regions: dict[str, str] = Field(default_factory=dict, description="region -> material name")

    @model_validator(mode="after")
    def _unique_materials(self):
        names = [m.name for m in self.materials]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ValueError(f"duplicate material name(s) {sorted(dup)}: names are unique across the "
                             f"terrain's own and its included materials")
        return self


class RoughnessSpec(_Model):
    """Seeded Fourier perturbation of a cylinder's radius (see analytic.py)."""

    rms: float = Field(0.01, ge=0, description="m")
    n_modes: int = Field(12, ge=0)
    wavelength_min: float = Field(0.2, gt=0, description="axial, m")
    wavelength_max: float = Field(2.0, gt=0, description="axial, m")
    m_min: int = Field(1, ge=0, description="lowest angular order")
    m_max: int = Field(6, ge=0, description="highest angular order")
    hurst: float = Field(0.8, ge=0, le=1)
    seed: int = 0

    @model_validator(mode="after")
    def _ranges(self):
        if self.wavelength_min > self.wavelength_max or self.m_min > self.m_max:
            raise ValueError("need wavelength_min <= wavelength_max and m_min <= m_max")
        return self

    def modes(self):
        return analytic.fourier_modes(self.seed, self.n_modes, self.rms, self.wavelength_min,
                                      self.wavelength_max, self.m_min, self.m_max, self.hurst)


class PlaneSpec(_Base):
    kind: Literal["plane"]
    origin: Vec3 = (0.0, 0.0, 0.0)
    tilt: float = Field(0.0, description="rad, slope of the plane")
    azimuth: float = Field(0.0, description="rad, direction (from +x) in which it rises")


class TubeSpec(_Base):
    kind: Literal["tube"]
    radius: float = Field(gt=0, description="m")
    origin: Vec3 = (0.0, 0.0, 0.0)
    axis: Vec3 = (1.0, 0.0, 0.0)
    roughness: RoughnessSpec | None = None

    @field_validator("axis")
    @classmethod
    def _axis(cls, axis):
        if not sum(a * a for a in axis) > 1e-24:
            raise ValueError(f"axis = {list(axis)}: the tube's axis direction must be a non-zero vector "
                             f"(e.g. [1, 0, 0])")
        return axis


class WallsSpec(_Base):
    kind: Literal["parallel_walls"]
    gap: float = Field(gt=0, description="m")
    origin: Vec3 = (0.0, 0.0, 0.0)
    yaw: float = Field(0.0, description="rad, heading of the channel")
    tilt: float = Field(0.0, description="rad, lean of both walls from vertical")


class UChannelSpec(_Base):
    kind: Literal["u_channel"]
    width: float = Field(gt=0, description="m")
    origin: Vec3 = (0.0, 0.0, 0.0)
    yaw: float = 0.0


class CrossSectionSpec(_Model):
    """A non-round moulin: a slot (analytic.SlotMoulin: flat walls 2b apart, half-round ends, exact distance)
    or the superellipse |x/a|^p + |y/b|^p = 1 (analytic.superellipse_section, a Fourier cylinder)."""

    shape: Literal["slot", "superellipse"] = Field("superellipse", description="slot | superellipse")
    semi_axes: tuple[float, float] = Field(description="m: a along the slot (in the vertical plane of the "
                                                       "heading), b across it")
    exponent: float = Field(2.0, ge=2, description="superellipse: 2 ellipse, 4 or more a rounded slot")
    max_order: int = Field(128, ge=2, le=512, description="highest angular order of the series")
    tolerance: float = Field(1e-5, gt=0, description="m, largest allowed error of the series")

    @field_validator("semi_axes")
    @classmethod
    def _positive(cls, v):
        if not (v[0] > 0 and v[1] > 0):
            raise ValueError(f"semi_axes = {list(v)}: both must be > 0 m")
        return v


class MoulinSpec(_Base):
    kind: Literal["moulin"]
    radius: float | None = Field(None, gt=0, description="mean shaft radius at the surface, m (round shaft)")
    cross_section: CrossSectionSpec | None = Field(None, description="a slot or elliptic shaft instead of radius")
    origin: Vec3 = Field((0.0, 0.0, 0.0), description="shaft axis at the ice surface")
    inclination: float = Field(0.0, ge=0.0, lt=1.5707963267948966,
                               description="rad of the shaft's axis from the vertical (0: a vertical shaft)")
    heading: float = Field(0.0, description="rad, azimuth from +x towards which the shaft descends; the "
                                            "cross-section's a axis lies in this vertical plane")
    slope: float = Field(0.0, description="dr/ds along the shaft's upward axis: > 0 narrows with depth")
    roughness: RoughnessSpec = RoughnessSpec(rms=0.05, n_modes=24, wavelength_min=0.3, wavelength_max=5.0,
                                             m_min=0, m_max=5)
    surface: bool = True
    meander: RoughnessSpec | None = Field(None, description="slot only: seeded sideways offset of the slot with "
                                                            "depth (both walls move together; angular orders "
                                                            "unused)")

    @model_validator(mode="after")
    def _one_shape(self):
        if (self.radius is None) == (self.cross_section is None):
            raise ValueError("give exactly one of 'radius' (a round shaft) or 'cross_section' "
                             "({semi_axes: [a, b], exponent: p})")
        if self.meander is not None and (self.cross_section is None or self.cross_section.shape != "slot"):
            raise ValueError("'meander' needs cross_section: {shape: slot, ...}")
        return self


class FractalSpec(_Model):
    size: int = Field(128, ge=4, description="samples per side")
    hurst: float = Field(0.8, gt=0, le=1)
    rms: float = Field(0.1, ge=0, description="m")
    seed: int = 0


class DemSpec(_Base):
    kind: Literal["dem"]
    file: str | None = None
    fractal: FractalSpec | None = None
    resolution: float | None = Field(None, gt=0, description="m per sample")
    origin: tuple[float, float] | None = None
    z_scale: float | None = None
    z_offset: float | None = None

    @model_validator(mode="after")
    def _one_source(self):
        if (self.file is None) == (self.fractal is None):
            raise ValueError("give exactly one of 'file' or 'fractal'")
        return self


class MeshSpec(_Base):
    kind: Literal["mesh"]
    file: str
    cells: int = Field(128, ge=4, description="grid cells along the longest side")
    resolution: float | None = Field(None, gt=0, description="grid spacing, m (overrides cells)")
    padding: float = Field(0.1, ge=0, description="m around the mesh")
    inside: Literal["solid", "free"] = "solid"
    open_surface: bool = False


class _FiniteModel(_Model):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


Positive = Annotated[float, Field(gt=0)]


class BoxSpec(_FiniteModel):
    """A block: an oriented box (see obstacles.py)."""

    center: Vec3 = Field(description="m")
    size: tuple[Positive, Positive, Positive] = Field(description="full edge lengths along the box's x, y, z, m")
    yaw: float = Field(0.0, description="rad, about z")
    roll: float = Field(0.0, description="rad, about x (fixed axes, applied first)")
    pitch: float = Field(0.0, description="rad, about y")


class SphereSpec(_FiniteModel):
    """A rock: a sphere; a centre below the ground makes a half-buried boulder."""

    center: Vec3 = Field(description="m")
    radius: float = Field(gt=0, description="m")


class KeepClearSpec(_FiniteModel):
    center: tuple[float, float] = Field(description="x, y of the robot's start, m")
    radius: float = Field(ge=0, description="m; no obstacle's footprint reaches into this disc")


class RandomObstaclesSpec(_FiniteModel):
    """Seeded random blocks and rocks (obstacles.scatter_obstacles), added to the listed ones."""

    count: int = Field(ge=0)
    seed: int = 0
    area: tuple[float, float, float, float] = Field(description="xmin, xmax, ymin, ymax of the centres, m")
    size: tuple[Positive, Positive] = Field(description="min, max of a block's edges and a rock's diameter, m")
    kinds: list[Literal["box", "sphere"]] = Field(default_factory=lambda: ["box", "sphere"], min_length=1)
    keep_clear: KeepClearSpec | None = None
    burial: tuple[float, float] = Field((0.0, 0.5), description="min, max depth of a rock's centre below the "
                                                                 "ground, in radii, each in [0, 1)")
    min_gap: float = Field(0.0, ge=0, description="m between footprints")

    @model_validator(mode="after")
    def _ranges(self):
        xmin, xmax, ymin, ymax = self.area
        if not (xmin < xmax and ymin < ymax):
            raise ValueError(f"area = {list(self.area)} m: need [xmin, xmax, ymin, ymax] with xmin < xmax "
                             f"and ymin < ymax")
        if self.size[0] > self.size[1]:
            raise ValueError(f"size = {list(self.size)} m: need [min, max] with 0 < min <= max")
        if not 0 <= self.burial[0] <= self.burial[1] < 1:
            raise ValueError(f"burial = {list(self.burial)}: need [min, max] with 0 <= min <= max < 1 "
                             f"(depth of a rock's centre below the ground, in radii)")
        return self


class ObstaclesSpec(_Base):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    kind: Literal["obstacles"]
    ground_height: float = Field(0.0, description="z of the flat ground, m")
    boxes: list[BoxSpec] = Field(default_factory=list)
    spheres: list[SphereSpec] = Field(default_factory=list)
    random: RandomObstaclesSpec | None = None


#: the base of every kind's spec model (description, materials, regions): third-party kinds subclass it
KindSpec = _Base


def _adapter(kinds: dict):
    """The schema of a terrain file: the union of the registered kinds' spec models (``kind:`` picks one)."""
    specs = tuple(k.spec for k in kinds.values())
    adapter = _ADAPTERS.get(specs)
    if adapter is None:
        adapter = _ADAPTERS[specs] = TypeAdapter(Annotated[Union[specs], Field(discriminator="kind")])
    return adapter


_ADAPTERS: dict = {}


def _kinds(registry=None) -> dict:
    from .kinds import terrain_kinds

    return terrain_kinds(registry)


# -- validation ------------------------------------------------------------------

def validate_spec(data, source: str = "<terrain>", base_dir: Path | None = None, registry=None):
    """dict -> spec model of its kind (the kinds ``registry`` holds: default, the built-ins and every
    installed plugin's); errors name the file:line and the key. ``{include: FILE}`` entries of
    ``materials`` are read relative to ``base_dir`` (default: the current folder)."""
    if not isinstance(data, dict):
        raise ConfigError(f"a terrain definition is a mapping with a 'kind' key, got {type(data).__name__}", source)
    kinds = _kinds(registry)
    if isinstance(data.get("kind"), str) and data["kind"] not in kinds:
        from .kinds import terrain_kind

        try:
            terrain_kind(data["kind"], registry)          # a name two plugins registered: say which
        except Exception as e:                            # noqa: BLE001 -- RegistryError
            raise ConfigError(str(e), where_in(data, ["kind"]) or source, "kind") from None
    spec_of_kind = {name: k.spec for name, k in kinds.items()}
    data_in = data
    data = _expand_materials(data, Path(".") if base_dir is None else Path(base_dir), source)
    try:
        return _adapter(kinds).validate_python(dict(data))
    except ValidationError as e:
        raise config_error(e, spec_of_kind.get(data.get("kind")), where=lambda loc: where_in(data_in, loc) or source,
                           drop=data.get("kind")) from None


# -- materials: inline entries and {include: FILE} ------------------------------------

def _expand_materials(data, base_dir: Path, source: str):
    """``data`` with every ``materials`` entry a Material (inline ones validated, includes read)."""
    items = data.get("materials")
    if not isinstance(items, list):
        return data            # absent (default) or malformed: the schema reports it
    where = data.where("materials") if hasattr(data, "where") else None
    where = where or source
    mats = []
    for i, entry in enumerate(items):
        at = (items.where(i) if hasattr(items, "where") else None) or where
        if isinstance(entry, dict) and "include" in entry:
            key = f"materials.{i}.include"
            extra = [k for k in entry if k != "include"]
            if extra:
                raise ConfigError(f"an include entry has the one key 'include', got also {', '.join(map(str, extra))}",
                                  at, key)
            ref = entry["include"]
            if not isinstance(ref, str) or not ref:
                raise ConfigError(f"'include' names a materials file (a path relative to the terrain file), got {ref!r}",
                                  at, key)
            path = base_dir / Path(ref).expanduser()
            if not path.is_file():
                raise ConfigError(f"materials file '{ref}' not found (looked for {path.resolve()})", at, key)
            mats.extend(read_material_file(path, included_from=at))
        else:
            mats.append(material_from_mapping(entry, at, f"materials.{i}"))
    out = type(data)(data) if isinstance(data, dict) else dict(data)
    out["materials"] = mats
    return out


def _materials(spec, cls, source):
    mats = tuple(spec.materials)
    names = [m.name for m in mats]
    rm = [0] * len(cls.regions)
    for region, mat in spec.regions.items():
        if region not in cls.regions:
            raise ConfigError(f"unknown region '{region}' for kind {spec.kind}; regions: {', '.join(cls.regions)}",
                              source, f"regions.{region}")
        if mat not in names:
            raise ConfigError(f"unknown material '{mat}'; materials: {', '.join(names)}", source, f"regions.{region}")
        rm[cls.regions.index(region)] = names.index(mat)
    return {"materials": mats, "region_material": rm}


def build_terrain(spec, base_dir: Path = Path("."), source: str = "<terrain>", name: str = "", store=None,
                  registry=None) -> Terrain:
    """Spec model (or plain dict) -> Terrain, by the factory of its registered kind."""
    from .kinds import BuildContext

    if isinstance(spec, dict):
        spec = validate_spec(spec, source, base_dir, registry)
    kind = _kinds(registry).get(spec.kind)
    if kind is None or not isinstance(spec, kind.spec):
        raise ConfigError(f"terrain kind '{spec.kind}' is not registered (valid: "
                          f"{', '.join(_kinds(registry))})", source, "kind")
    kw = _materials(spec, kind.terrain, source)
    kw["name"] = name or spec.kind
    try:
        return kind.build(spec, BuildContext(Path(base_dir), source, store), **kw)
    except ValueError as e:
        raise ConfigError(str(e), source) from None


# -- the built-in kinds' factories (registered in builtin_terrain_kinds) ------------------

def _build_plane(spec: PlaneSpec, ctx, **kw) -> Terrain:
    return analytic.PlaneTerrain(spec.origin, spec.tilt, spec.azimuth, **kw)


def _build_tube(spec: TubeSpec, ctx, **kw) -> Terrain:
    modes = spec.roughness.modes() if spec.roughness else None
    return analytic.FourierCylinder(spec.radius, spec.origin, spec.axis, modes=modes, **kw)


def _build_walls(spec: WallsSpec, ctx, **kw) -> Terrain:
    return analytic.ParallelWalls(spec.gap, spec.origin, spec.yaw, spec.tilt, **kw)


def _build_u_channel(spec: UChannelSpec, ctx, **kw) -> Terrain:
    return analytic.UChannel(spec.width, spec.origin, spec.yaw, **kw)


def _build_moulin(spec: MoulinSpec, ctx, **kw) -> Terrain:
    shaft = _moulin_shaft(spec)
    if isinstance(shaft, tuple):                        # a slot: its own exact class
        (a, b), axis, along = shaft
        mz = spec.meander
        meander = None if mz is None else analytic.fourier_modes(
            mz.seed, mz.n_modes, mz.rms, mz.wavelength_min, mz.wavelength_max, 0, 0, mz.hurst)
        return analytic.SlotMoulin(a, b, spec.origin, axis, along, spec.slope, spec.roughness.modes(),
                                   spec.surface, meander, **kw)
    return analytic.Moulin(shaft, spec.surface, **kw)


def _build_mesh(spec: MeshSpec, ctx, **kw) -> Terrain:
    return mesh.mesh_terrain(ctx.base_dir / spec.file, spec.cells, spec.resolution, spec.padding, spec.inside,
                             spec.open_surface, store=ctx.store, **kw)


def builtin_terrain_kinds() -> tuple:
    """snakesim's own kinds, in the order the schema lists them (components/plugin.py registers them)."""
    from .kinds import TerrainKind

    return (TerrainKind("plane", PlaneSpec, analytic.PlaneTerrain, _build_plane),
            TerrainKind("tube", TubeSpec, analytic.FourierCylinder, _build_tube),
            TerrainKind("parallel_walls", WallsSpec, analytic.ParallelWalls, _build_walls),
            TerrainKind("u_channel", UChannelSpec, analytic.UChannel, _build_u_channel),
            TerrainKind("moulin", MoulinSpec, analytic.Moulin, _build_moulin),
            TerrainKind("dem", DemSpec, dem.HeightField,
                        lambda spec, ctx, **kw: _build_dem(spec, ctx.base_dir, ctx.source, kw)),
            TerrainKind("obstacles", ObstaclesSpec, obstacles.ObstacleField,
                        lambda spec, ctx, **kw: _build_obstacles(spec, ctx.source, kw)),
            TerrainKind("mesh", MeshSpec, mesh.SdfGrid, _build_mesh))


def _moulin_shaft(spec: MoulinSpec):
    """The shaft: its axis (upward, tilted ``inclination`` away from the ``heading``), round or with the
    cross-section's a axis in the heading's vertical plane (perpendicular to the axis). A slot: the tuple
    ((a, b), axis, a axis) for analytic.SlotMoulin."""
    si, ci, sh, ch = np.sin(spec.inclination), np.cos(spec.inclination), np.sin(spec.heading), np.cos(spec.heading)
    axis = (-si * ch, -si * sh, ci)
    if spec.cross_section is None:
        return analytic.FourierCylinder(spec.radius, spec.origin, axis, spec.slope, modes=spec.roughness.modes())
    x = spec.cross_section
    R = analytic.frame_from_axis(axis)
    along = np.array([ci * ch, ci * sh, si])                     # the a axis, ⟂ the shaft axis
    if x.shape == "slot":
        return x.semi_axes, axis, along
    angle = float(np.arctan2(along @ R[:, 1], along @ R[:, 0]))
    rho0, section, _ = analytic.superellipse_section(x.semi_axes[0], x.semi_axes[1], x.exponent, angle,
                                                     x.max_order, x.tolerance)
    return analytic.FourierCylinder(rho0, spec.origin, axis, spec.slope, modes=spec.roughness.modes(),
                                    section=section)


def _build_obstacles(spec: ObstaclesSpec, source: str, kw) -> Terrain:
    blocks = [obstacles.Block(b.center, b.size, b.yaw, b.roll, b.pitch) for b in spec.boxes]
    rocks = [obstacles.Rock(s.center, s.radius) for s in spec.spheres]
    r = spec.random
    if r is not None:
        clear = None if r.keep_clear is None else (r.keep_clear.center, r.keep_clear.radius)
        try:
            more_blocks, more_rocks = obstacles.scatter_obstacles(
                r.count, r.seed, r.area, r.size, tuple(r.kinds), clear, r.burial, r.min_gap, spec.ground_height,
                occupied=blocks + rocks)
        except ValueError as e:
            raise ConfigError(str(e), source, "random.count") from None
        blocks, rocks = blocks + more_blocks, rocks + more_rocks
    try:
        return obstacles.ObstacleField(spec.ground_height, blocks, rocks, **kw)
    except ValueError as e:
        raise ConfigError(str(e), source) from None


def _build_dem(spec: DemSpec, base_dir: Path, source: str, kw) -> Terrain:
    if spec.fractal is not None:
        f = spec.fractal
        z, meta, where = dem.fractal_heights(f.size, f.hurst, f.rms, f.seed), {}, source
    else:
        path = base_dir / spec.file
        z, meta, where = dem.read_grid(path), dem.sidecar(path), str(path)
    res = spec.resolution if spec.resolution is not None else meta.get("resolution")
    if res is None:
        raise ConfigError("DEM needs 'resolution' (m per sample), in the terrain file or a .meta.yaml sidecar",
                          source, "resolution")
    scale = spec.z_scale if spec.z_scale is not None else meta.get("z_scale", 1.0)
    offset = spec.z_offset if spec.z_offset is not None else meta.get("z_offset", 0.0)
    origin = spec.origin if spec.origin is not None else tuple(meta.get("origin", (0.0, 0.0)))
    if spec.fractal is not None and spec.origin is None:   # centre procedural patches on the origin
        origin = (-0.5 * (z.shape[1] - 1) * res, -0.5 * (z.shape[0] - 1) * res)
    return dem.HeightField(offset + scale * z, res, origin, source=where, **kw)


# -- lookup ----------------------------------------------------------------------

def terrain_dir() -> Path:
    return Path(str(files("snakesim.terrains")))


def available_terrains() -> list[str]:
    return sorted(p.name[:-5] for p in terrain_dir().glob("*.yaml") if not p.name.endswith(".meta.yaml"))


def resolve_terrain(ref: str) -> Path:
    """A name in the terrains/ package folder, or a path to a YAML or mesh file."""
    path = Path(ref).expanduser()
    if path.is_file():
        return path
    if "/" not in ref and not ref.endswith((".yaml", ".yml")):
        named = terrain_dir() / f"{ref}.yaml"
        if named.is_file():
            return named
    names = available_terrains()
    close = difflib.get_close_matches(Path(ref).stem, names, n=3, cutoff=0.5)
    hint = f" Did you mean: {', '.join(close)}?" if close else ""
    raise ConfigError(f"no terrain '{ref}': not a file, and not a terrain name "
                      f"(available: {', '.join(names) or 'none'}).{hint}")


def terrain_materials(ref: str) -> tuple[Material, ...]:
    """The materials of a terrain (name in terrains/ or path), read and validated without
    building its geometry; an imported mesh has the default material."""
    path = resolve_terrain(ref)
    if path.suffix.lower() in mesh.MESH_SUFFIXES:
        return (Material(),)
    return tuple(validate_spec(load_yaml(path), str(path), path.parent).materials)


def load_terrain(ref: str | dict, store=None, registry=None) -> Terrain:
    """Terrain from a name in terrains/, a path (YAML definition or OBJ/STL/PLY mesh) or an inline dict;
    ``registry``: whose terrain kinds (default: the built-ins and every installed plugin's)."""
    if isinstance(ref, dict):
        return build_terrain(ref, Path("."), "<inline terrain>", store=store, registry=registry)
    path = resolve_terrain(ref)
    if path.suffix.lower() in mesh.MESH_SUFFIXES:
        return mesh.mesh_terrain(path, store=store, name=path.stem)
    data = load_yaml(path)
    spec = validate_spec(data, str(path), path.parent, registry)
    return build_terrain(spec, path.parent, str(path), name=path.stem, store=store, registry=registry)
