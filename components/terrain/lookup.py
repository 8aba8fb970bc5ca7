"""Terrain names: the YAML files shipped in the ``snakesim.terrains`` package folder, and a reference
(a name there, or a path to a YAML or mesh file) resolved to its file, with close names proposed.
"""

from __future__ import annotations

import difflib
from importlib.resources import files
from pathlib import Path

from snakesim.framework import ConfigError


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
