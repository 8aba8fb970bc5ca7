"""Terrain kinds: what the ``kind:`` key of a terrain YAML file can name.

A kind is one registration (:class:`TerrainKind`), made through the plugin hook
``snakesim_register_terrain_kinds(registry)`` with ``registry.add_terrain_kind(kind)``:

    name      the ``kind:`` value (third-party kinds carry their package's prefix)
    spec      the pydantic model of its YAML mapping: a ``kind: Literal[name]`` field plus the kind's
              own keys; subclass ``KindSpec`` (terrain/spec_models.py) for ``description``, ``materials``
              and ``regions``
    terrain   the Terrain class it builds (its ``regions`` name what ``regions:`` may map)
    build     ``build(spec, context, **kw) -> Terrain``: ``kw`` holds ``materials``, ``region_material``
              and ``name`` for the Terrain's constructor; ``context`` (:class:`BuildContext`) the folder
              files are relative to, the source for error messages and the terrain store. A ValueError
              it raises is reported as a configuration error naming the file.

The schema of a terrain file is the union of the registered kinds' ``spec`` models
(terrain/spec.py builds it), so a wrong key, value or kind is reported with the file, the
line, the key and the valid choices whoever registered the kind. Everything a consumer needs
beyond the query (a display mesh, the hull back end's geometry, how the sensors refine hits)
is a method of the Terrain class with a default on :class:`~.base.Terrain`: see its docstring.
snakesim's own kinds register through the same hook (components/plugin.py).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Callable

from .base import Terrain


@dataclasses.dataclass(frozen=True)
class BuildContext:
    """Where a terrain definition came from: ``base_dir`` (files it names are relative to it),
    ``source`` (file or ``<inline terrain>``, for messages), ``store`` (terrain store folder or None)."""

    base_dir: Path = Path(".")
    source: str = "<terrain>"
    store: object = None


@dataclasses.dataclass(frozen=True, eq=False)
class TerrainKind:
    """One terrain kind: its YAML name, spec model, Terrain class and factory (module docstring)."""

    name: str
    spec: type
    terrain: type[Terrain]
    build: Callable[..., Terrain]

    def __post_init__(self):
        field = getattr(self.spec, "model_fields", {}).get("kind")
        if field is None or getattr(field.annotation, "__args__", None) != (self.name,):
            raise TypeError(f"terrain kind '{self.name}': its spec model {self.spec.__name__} needs the field "
                            f"kind: Literal[{self.name!r}]")
        if not (isinstance(self.terrain, type) and issubclass(self.terrain, Terrain)):
            raise TypeError(f"terrain kind '{self.name}': {self.terrain!r} is not a Terrain subclass")


def terrain_kinds(registry=None) -> dict[str, TerrainKind]:
    """name -> TerrainKind of ``registry`` (default: built-ins plus every installed plugin), the
    built-in kinds first (the order error messages list them in)."""
    from snakesim.framework.registry import default_terrain_kinds

    reg = registry or default_terrain_kinds()
    return reg.builtins_first(reg.terrain_kinds, "terrain kind")


def terrain_kind(name: str, registry=None) -> TerrainKind | None:
    """The registered kind ``name`` (None if unknown); a name two plugins registered is an error."""
    if registry is None:
        from snakesim.framework.registry import default_terrain_kinds

        registry = default_terrain_kinds()
    registry._clashed("terrain kind", name)
    return registry.terrain_kinds.get(name)
