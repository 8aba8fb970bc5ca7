"""Contact materials: the one schema of what a surface is made of, and the one packing of
materials for the numba contact kernels.

A :class:`Material` is named and carries

    k      N/m     penalty stiffness                                   (paper eq. 2)  > 0
    c      N·s/m   penalty damping                                     (paper eq. 2)  ≥ 0
    mu     1       friction coefficient (parallel to the threads)      (eqs. 1, 6)    ≥ 0
    ev_a   1       ‖e_v‖ at zero normal force   } fig. 6 fit ‖e_v‖ = ev_a + ev_b·F_n;   > 0
    ev_b   1/N     d‖e_v‖/dF_n                  } ev_a = 1, ev_b = 0 is isotropic

and, for the perception sensors (cameras and lidar; contact never reads them),

    albedo 1       diffuse (Lambertian) reflectance at the lidar's wavelength and for a grey
                   camera image                                                  in [0, 1]
    color  1       linear RGB diffuse reflectance of a colour camera image       each in [0, 1]
    texture        procedural albedo pattern: none, or checker (cubes of texture_size m
                   in the world alternate between albedo and albedo·(1 − texture_contrast);
                   perception/textures.py)

Where materials come from:

- a terrain lists them (terrain YAML ``materials:``, first = default of every region);
  an entry ``{include: FILE}`` splices in the materials of a materials file, a YAML file
  with one key ``materials:`` holding a list in the same form (path relative to the
  terrain file). ``snakesim fit-friction --out FILE`` writes such a file.
- a contact component's ``material:`` parameter is a :class:`MaterialPatch`: the same
  fields, each optional, replacing that field of every terrain material.
- ``point_contact`` has one ``material:`` of its own.

Component knobs are not material properties and stay on the components: the slip
regularisation (v_ε, mode), the ‖e_v‖ floor the kernels clamp at, and ``fn_max``, the top
of the normal load per contact the component is used for. ‖e_v‖ ≤ 0 reverses friction
along ê_v (an energy source), so each component checks that ev_a + ev_b·F_n ≥ ev_floor
over its [0, fn_max] (:func:`ev_range_problem`); a material alone only knows ev_a > 0.

The kernels read a material table, (n_materials, 5) float64, from :func:`material_table`,
the one place that packs it; columns by name: ``table[i, MU]`` (K, C, MU, EV_A, EV_B).
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Literal, Optional

import numpy as np
from pydantic import ConfigDict, Field, ValidationError, ValidationInfo, create_model, field_validator

from snakesim.framework import ConfigError, Params
from snakesim.framework.yaml_source import load_yaml

#: column indices of the material table (numba kernels read them as compile-time constants)
K, C, MU, EV_A, EV_B = range(5)
#: Material field of each column: COLUMNS[K] == "k"
COLUMNS = ("k", "c", "mu", "ev_a", "ev_b")

_RULES = {   # field -> (unit, test, requirement, what it is)
    "k": ("N/m", lambda v: v > 0, "> 0", "penalty stiffness, eq. 2"),
    "c": ("N·s/m", lambda v: v >= 0, "≥ 0", "penalty damping, eq. 2"),
    "mu": ("", lambda v: v >= 0, "≥ 0", "friction coefficient"),
    "ev_a": ("", lambda v: v > 0, "> 0", "‖e_v‖ at zero normal force; ≤ 0 reverses friction along the threads"),
    "ev_b": ("1/N", lambda v: True, "", "slope of ‖e_v‖ in F_n"),
}


def _field_problem(field: str, value: float) -> str | None:
    unit, ok, need, what = _RULES[field]
    if not math.isfinite(value):
        return f"{field} = {value} is not a finite number"
    shown = f"{field} = {value:g}" + (f" {unit}" if unit else "")
    if not ok(value):
        return f"{shown} must be {need} ({what})"
    return None


class Material(Params):
    """Contact parameters of one surface material (terrain region); see the module docstring."""

    # finiteness is checked by the validators below, whose messages name the material
    model_config = ConfigDict(allow_inf_nan=True)

    name: str = Field("ice", min_length=1, description="referred to by a terrain's regions")
    k: float = Field(1.0e5, description="N/m, penalty stiffness (eq. 2), > 0")
    c: float = Field(1.0e3, description="N·s/m, penalty damping (eq. 2), ≥ 0")
    mu: float = Field(0.3, description="friction coefficient (eqs. 1, 6), ≥ 0")
    ev_a: float = Field(1.0, description="‖e_v‖ at zero normal force, > 0 (fig. 6 fit)")
    ev_b: float = Field(0.0, description="1/N, d‖e_v‖/dF_n (fig. 6 fit)")
    albedo: float = Field(0.6, description="diffuse reflectance seen by lidar and grey cameras, in [0, 1]")
    color: tuple[float, float, float] = Field((0.80, 0.90, 0.97),
                                              description="linear RGB diffuse reflectance for colour cameras, "
                                                          "each in [0, 1]")

    texture: Literal["none", "checker"] = Field("none", description="procedural albedo pattern for sensors")
    texture_size: float = Field(0.1, gt=0, allow_inf_nan=False, description="m, checker square size")
    texture_contrast: float = Field(0.5, ge=0, le=1, description="dark squares reflect albedo·(1 − contrast)")

    @field_validator("albedo")
    @classmethod
    def _check_albedo(cls, v: float, info: ValidationInfo) -> float:
        if not (math.isfinite(v) and 0.0 <= v <= 1.0):
            raise ValueError(f"material '{info.data.get('name', '?')}': albedo = {v} must be in [0, 1] "
                             "(diffuse reflectance)")
        return v

    @field_validator("color")
    @classmethod
    def _check_color(cls, v, info: ValidationInfo):
        if not all(math.isfinite(c) and 0.0 <= c <= 1.0 for c in v):
            raise ValueError(f"material '{info.data.get('name', '?')}': color = {list(v)} must be three "
                             "values in [0, 1] (linear RGB reflectance)")
        return v

    @field_validator(*COLUMNS)
    @classmethod
    def _check(cls, v: float, info: ValidationInfo) -> float:
        problem = _field_problem(info.field_name, v)
        if problem:
            raise ValueError(f"material '{info.data.get('name', '?')}': {problem}")
        return v

    def override(self, **fields) -> "Material":
        """This material with the given fields replaced (validated): ``m.override(mu=0.1)``."""
        return MaterialPatch(**fields).apply(self)

    def row(self) -> tuple[float, ...]:
        """The table row: values in COLUMNS order."""
        return tuple(float(getattr(self, f)) for f in COLUMNS)


class _PatchBase(Params):
    @field_validator("*")
    @classmethod
    def _check(cls, v, info: ValidationInfo):
        problem = None if v is None else _field_problem(info.field_name, v)
        if problem:
            raise ValueError(f"material override: {problem}")
        return v

    def given(self) -> dict:
        """The fields this patch sets."""
        return {f: v for f, v in self if v is not None}

    def apply(self, material: Material) -> Material:
        """``material`` with the given fields replaced."""
        given = self.given()
        return Material(**{**material.model_dump(), **given}) if given else material


#: Material's optional view of its contact fields (COLUMNS; default None = keep the material's
#: value): a contact component's ``material`` parameter. Generated from Material, so the
#: two cannot drift apart.
MaterialPatch = create_model(
    "MaterialPatch", __base__=_PatchBase, __module__=__name__,
    **{f: (Optional[Material.model_fields[f].annotation],
           Field(None, description=f"replaces the terrain material's {f}: {Material.model_fields[f].description}"))
       for f in COLUMNS})
MaterialPatch.__doc__ = "Replaces the given fields of every terrain material (None: keep the terrain's value)."


def ev_range_problem(material: Material, fn_max: float, ev_floor: float) -> str | None:
    """Why ‖e_v‖ = ev_a + ev_b·F_n falls below ev_floor on [0, fn_max] N, or None if it does not."""
    a, b = material.ev_a, material.ev_b
    # linear in F_n: the minimum over [0, fn_max] is at an end
    at = 0.0 if a <= a + b * fn_max else fn_max
    lo = a + b * at
    if lo >= ev_floor:
        return None
    law = f"{a:g} {'−' if b < 0 else '+'} {abs(b):g}·F_n"
    return (f"material '{material.name}': ‖e_v‖ = ev_a + ev_b·F_n = {law} falls to {lo:g} at "
            f"F_n = {at:g} N, below ev_floor = {ev_floor:g} on the load range [0, fn_max = {fn_max:g}] N; "
            f"a non-positive ‖e_v‖ reverses friction along ê_v. Lower fn_max or refit the material.")


def material_table(materials, patch: MaterialPatch | None = None, *, fn_max: float, ev_floor: float,
                   owner: str = "") -> np.ndarray:
    """The kernels' material table: (len(materials), 5) float64, C-contiguous; row i is
    ``materials[i]`` with ``patch`` applied, columns K, C, MU, EV_A, EV_B.

    Checks ‖e_v‖ ≥ ev_floor over [0, fn_max] N for every row; a failure is a ConfigError
    naming ``owner`` (the component), the material and the values.
    """
    rows = []
    for m in materials:
        if patch is not None:
            try:
                m = patch.apply(m)
            except ValueError as e:      # pydantic's ValidationError is one
                raise ConfigError(f"material override on '{m.name}': {e}", owner or None, "material") from None
        problem = ev_range_problem(m, fn_max, ev_floor)
        if problem:
            raise ConfigError(problem, owner or None)
        rows.append(m.row())
    if not rows:
        raise ConfigError("no materials to pack", owner or None, "material")
    return np.ascontiguousarray(np.array(rows, dtype=np.float64).reshape(len(rows), len(COLUMNS)))


# -- materials in YAML: a mapping per material, materials files -----------------------------

def material_from_mapping(entry, where: str | None, key: str, note: str = "") -> Material:
    """One material mapping (YAML) -> Material; a ConfigError names file:line, the key and the value."""
    if isinstance(entry, Material):
        return entry
    if not isinstance(entry, dict):
        raise ConfigError(f"a material is a mapping with keys {', '.join(Material.model_fields)}, got {entry!r}{note}",
                          where, key)
    try:
        return Material.model_validate(dict(entry))
    except ValidationError as e:
        errs = e.errors()
        err = next((x for x in errs if x["type"] == "extra_forbidden"), errs[0])
        field = err["loc"][0] if err["loc"] else None
        if err["type"] == "extra_forbidden":
            close = difflib.get_close_matches(str(field), list(Material.model_fields), n=1)
            msg = (f"unknown key '{field}'" + (f"; did you mean '{close[0]}'?" if close else "")
                   + f" valid keys: {', '.join(Material.model_fields)}")
        elif err["type"] == "value_error":
            msg = err["msg"].removeprefix("Value error, ")
        else:
            msg = f"material '{entry.get('name', Material.model_fields['name'].default)}': {field}: {err['msg']}" \
                  f" (got {err.get('input')!r})"
        at = entry.where(field) if hasattr(entry, "where") and field is not None else None
        raise ConfigError(msg + note, at or where, f"{key}.{field}" if field is not None else key) from None


def read_material_file(path, included_from: str = "") -> list[Material]:
    """The materials of a materials file: YAML with one key, ``materials``, a non-empty list of
    material mappings (what ``snakesim fit-friction --out`` writes). Errors name the file:line,
    the key and the value (and ``included_from``, the terrain file:line that includes it)."""
    path = Path(path)
    note = f" (materials file included at {included_from})" if included_from else ""
    if not path.is_file():
        raise ConfigError(f"materials file not found{note}", str(path))
    data = load_yaml(path)
    src = str(path)
    if not isinstance(data, dict) or set(data) != {"materials"}:
        got = (f"keys {', '.join(map(str, data))}" if data else "an empty file") if isinstance(data, dict) \
            else f"a {type(data).__name__}"
        raise ConfigError(f"a materials file has one key, 'materials' (a list of materials), got {got}{note}", src)
    items = data["materials"]
    where = (data.where("materials") if hasattr(data, "where") else None) or src
    if not isinstance(items, list) or not items:
        hint = (" (a mapping name -> values, as older `snakesim fit-friction` wrote: make it a list, "
                "- {name: NAME, k: ..., c: ..., mu: ..., ev_a: ..., ev_b: ...})") if isinstance(items, dict) else ""
        raise ConfigError(f"'materials' is a non-empty list of materials, got {items!r}{hint}{note}", where,
                          "materials")
    out = []
    for i, entry in enumerate(items):
        at = (items.where(i) if hasattr(items, "where") else None) or where
        if isinstance(entry, dict) and "include" in entry:
            raise ConfigError(f"includes do not nest: a materials file lists materials, not {{include: ...}}{note}",
                              at, f"materials.{i}.include")
        out.append(material_from_mapping(entry, at, f"materials.{i}", note))
    return out
