"""A terrain definition's ``materials:`` list with its ``{include: FILE}`` entries read: each entry becomes
a Material (inline ones validated, a materials file's put where its include stands), before the
schema (spec_models.py) validates the definition. Errors name the file:line and the key.
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
