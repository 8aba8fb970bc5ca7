"""What a consumer derives from a terrain, rebuilt when the terrain's state changes: the one rule.

A consumer that builds something from a terrain once and keeps it (the sensors' Embree scene, the
viewer's mesh) holds it in a :class:`TerrainDerived`:

    scene = TerrainDerived(lambda terrain: build_scene(terrain))     # per run: in u.cache
    scene.get(terrain)          # every step: built from this terrain and state version, else rebuilt

A value computed elsewhere from the terrain (with other inputs: a placement's nearest points at
some link poses) is recorded with ``keep(terrain, value)`` and trusted while not ``stale(terrain)``.

It rebuilds when the terrain *object* is another one or ``terrain.state.version`` moved since the
build (terrain/base.py: a deformable kind changes its state arrays in place, then calls
``state.changed()``); otherwise it returns what it built. A static kind's version stays 0, so after
the first build a step costs one identity and one integer comparison.
"""

from __future__ import annotations

from typing import Callable, Generic, TypeVar

from .base import Terrain

T = TypeVar("T")


class TerrainDerived(Generic[T]):
    """One consumer's value derived from a terrain (module docstring).

    ``build(terrain) -> value`` (None: values come only through :meth:`keep`); ``terrain`` and
    ``version``: the object and the state version the value was built from (None and −1 before the
    first); ``builds``: how many builds so far."""

    __slots__ = ("_build", "terrain", "version", "value", "builds")

    def __init__(self, build: Callable[[Terrain], T] | None = None):
        self._build = build
        self.terrain: Terrain | None = None
        self.version = -1
        self.value: T | None = None
        self.builds = 0

    def stale(self, terrain: Terrain) -> bool:
        """Whether ``terrain`` is not what the value was built from (another object, or its state
        changed since)."""
        return terrain is not self.terrain or terrain.state.version != self.version

    def get(self, terrain: Terrain) -> T:
        """The value for ``terrain`` as it is now: built again only when :meth:`stale`."""
        if self.stale(terrain):
            # the version is read before building: a change during the build leaves it stale
            version = terrain.state.version
            self.value = self._build(terrain)
            self.terrain, self.version = terrain, version
            self.builds += 1
        return self.value

    def keep(self, terrain: Terrain, value: T) -> None:
        """Record ``value`` as derived from ``terrain`` as it is now (computed by the caller)."""
        self.value, self.terrain, self.version = value, terrain, terrain.state.version
