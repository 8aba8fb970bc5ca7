"""A terrain definition's ``{include: FILE}`` entries read before the schema (spec_models.py) validates it:
in the ``materials:`` list each entry becomes a Material (inline ones validated, a materials file's put where
its include stands); any other key whose value is ``{include: FILE}`` gets the mapping that file holds (a
soil's parameter set shared by several terrains: ``soil: {include: soils/snow-us.yaml}``). Paths are
relative to the terrain file, else to snakesim's terrains folder (so a copied terrain file still finds the
shipped soils); errors name the file:line and the key, and an included file's own keys keep
their file:line.
"""

from __future__ import annotations

from pathlib import Path

from snakesim.components.materials import material_from_mapping, read_material_file
from snakesim.framework import ConfigError


def expand_materials(data, base_dir: Path, source: str):
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


def expand_includes(data, base_dir: Path, source: str):
    """``data`` with every top-level ``key: {include: FILE}`` (but ``materials``, whose list has its own
    includes: expand_materials) replaced by the mapping in FILE (YAML, relative to ``base_dir``)."""
    from snakesim.framework.yaml_source import LocatedDict, load_yaml

    keys = [k for k, v in data.items() if k != "materials" and isinstance(v, dict) and "include" in v]
    if not keys:
        return data
    out = LocatedDict(data)
    out.pos, out.file, out.line = dict(getattr(data, "pos", {})), getattr(data, "file", None), getattr(data, "line",
                                                                                                       None)
    for key in keys:
        entry = data[key]
        at = (data.where(key) if hasattr(data, "where") else None) or source
        extra = [k for k in entry if k != "include"]
        if extra:
            raise ConfigError(f"an include has the one key 'include', got also {', '.join(map(str, extra))}", at,
                              f"{key}.include")
        ref = entry["include"]
        if not isinstance(ref, str) or not ref:
            raise ConfigError(f"'include' names a YAML file (a path relative to the terrain file), got {ref!r}", at,
                              f"{key}.include")
        # relative to the terrain file, else among the shipped terrains (a copied terrain file keeps its soil)
        from .lookup import terrain_dir

        looked = [base_dir / Path(ref).expanduser(), terrain_dir() / ref]
        path = next((c for c in looked if c.is_file()), None)
        if path is None:
            raise ConfigError(f"{key}: included file '{ref}' not found (looked for "
                              f"{' and '.join(str(c.resolve()) for c in looked)})", at, f"{key}.include")
        included = load_yaml(path)
        if not isinstance(included, dict):
            raise ConfigError(f"{key}: an included file holds a mapping (the keys {key} takes), got "
                              f"{type(included).__name__}", str(path), key)
        out[key] = included
    return out
