"""YAML terrain definitions: the pydantic schema of the built-in kinds (``kind:`` discriminator) and
:data:`KindSpec`, the base of every kind's model (spec.py validates, builds and loads).

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

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from snakesim.components.materials import Material

from . import analytic

Vec3 = tuple[float, float, float]


def open_quadrant_deg(v: float, key: str, meaning: str) -> float:
    """An angle validator: ``v`` (deg) strictly between 0 and 90, else a ValueError naming ``key`` and what the
    angle is (the soil's friction angle, the berms' repose)."""
    if not 0.0 < v < 90.0:
        raise ValueError(f"{key} = {v} deg: must be in (0, 90) degrees{meaning}")
    return v


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
    sign: Literal["pseudonormal", "winding_number"] = Field(
        "pseudonormal", description="pseudonormal: the side the face normals point to is outside; "
                                    "winding_number: the side the mesh encloses (|w| >= 1/2) is inside, whichever "
                                    "way its normals point (open scans; terrain/mesh_winding.py)")
    exact_band: float = Field(0.0, ge=0, description="m; where the grid's |d| is below this, the exact "
                                                     "point-triangle distance (terrain/mesh_exact.py); 0: the grid "
                                                     "everywhere")

    @model_validator(mode="after")
    def _band_in_grid(self):
        if self.exact_band > self.padding:
            raise ValueError(f"exact_band = {self.exact_band} m is larger than padding = {self.padding} m: the band "
                             f"must lie inside the grid (raise padding or lower exact_band)")
        return self


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
