"""Terrain definitions, validated and built: :func:`validate_spec` (dict -> the spec model of its kind,
against the union of the registered kinds' models), :func:`build_terrain` (-> Terrain, by its kind's
factory), :func:`load_terrain` (a name, a path or an inline dict) and :func:`terrain_materials`.

The jobs around them have their own modules, re-exported here: the schema and its YAML form
(spec_models.py), the ``{include: FILE}`` materials entries (includes.py), terrain names and files
(lookup.py) and the built-in kinds' factories (builtin_kinds.py).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Union

from pydantic import Field, TypeAdapter, ValidationError

from snakesim.components.materials import Material
from snakesim.framework import ConfigError
from snakesim.framework.validation_errors import config_error, where_in
from snakesim.framework.yaml_source import load_yaml

from . import mesh
from .base import Terrain
from .builtin_kinds import builtin_terrain_kinds  # noqa: F401  (re-exported)
from .includes import expand_includes, expand_materials
from .lookup import available_terrains, resolve_terrain, terrain_dir  # noqa: F401  (re-exported)
from .spec_models import (BoxSpec, CrossSectionSpec, DemSpec, FractalSpec, KeepClearSpec, KindSpec,  # noqa: F401
                          MeshSpec, MoulinSpec, ObstaclesSpec, PlaneSpec, Positive, RandomObstaclesSpec, RoughnessSpec,
                          SphereSpec, TubeSpec, UChannelSpec, Vec3, WallsSpec)


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
    folder = Path(".") if base_dir is None else Path(base_dir)
    data = expand_includes(data, folder, source)
    data_in = data
    data = expand_materials(data, folder, source)
    try:
        return _adapter(kinds).validate_python(dict(data))
    except ValidationError as e:
        raise config_error(e, spec_of_kind.get(data.get("kind")), where=lambda loc: where_in(data_in, loc) or source,
                           drop=data.get("kind")) from None


# -- building ------------------------------------------------------------------

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


# -- loading -------------------------------------------------------------------

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
