"""Component and integrator registry, filled through pluggy hooks.

Set-up follows pytest's order: create the manager, add hookspecs, register the
built-in plugins, load third-party entry points (group ``snakesim``), then ask
every plugin to register. Built-ins use exactly the hooks a third party uses.
"""

from __future__ import annotations

import difflib
import importlib
from functools import lru_cache

import pluggy

from . import hookspecs
from .component import Component
from .errors import RegistryError

ENTRY_POINT_GROUP = "snakesim"

#: modules registered as plugins before entry points are loaded
BUILTIN_PLUGINS = (
    "snakesim.framework.integrators.plugin",
    "snakesim.components.plugin",
    "snakesim.assemblies.plugin",
)


def _close(name: str, names) -> str:
    matches = difflib.get_close_matches(name, list(names), n=5, cutoff=0.5)
    return f"; did you mean {', '.join(repr(m) for m in matches)}?" if matches else ""


class Registry:
    def __init__(self, plugin_manager: pluggy.PluginManager | None = None):
        self.components: dict[str, type[Component]] = {}
        self.integrators: dict[str, type] = {}
        self.origins: dict[str, str] = {}
        self.pm = plugin_manager

    # -- filled by hooks --------------------------------------------------------
    def add_component(self, cls: type[Component], name: str | None = None) -> None:
        if not (isinstance(cls, type) and issubclass(cls, Component)):
            raise RegistryError(f"{cls!r} is not a snakesim Component subclass")
        name = name or cls.type_name or _snake(cls.__name__)
        if name in self.components and self.components[name] is not cls:
            old = self.components[name]
            raise RegistryError(
                f"component type '{name}' registered twice: {old.__module__}.{old.__qualname__} "
                f"and {cls.__module__}.{cls.__qualname__}")
        if not cls.type_name:
            cls.type_name = name
        self.components[name] = cls

    def add_integrator(self, cls: type, name: str | None = None) -> None:
        name = name or cls.name
        if name in self.integrators and self.integrators[name] is not cls:
            raise RegistryError(f"integrator '{name}' registered twice")
        self.integrators[name] = cls

    # -- look-ups -----------------------------------------------------------------
    def component(self, name: str) -> type[Component]:
        try:
            return self.components[name]
        except KeyError:
            raise RegistryError(f"unknown component type '{name}'{_close(name, self.components)} "
                                f"(`snakesim components` lists all {len(self.components)})") from None

    def integrator(self, name: str) -> type:
        try:
            return self.integrators[name]
        except KeyError:
            raise RegistryError(f"unknown integrator '{name}'{_close(name, self.integrators)}; "
                                f"valid: {', '.join(sorted(self.integrators))}") from None

    def assembly_paths(self) -> list:
        paths = []
        for group in self.pm.hook.snakesim_assembly_paths():
            paths.extend(group)
        return paths

    def default_assembly(self) -> str | None:
        return self.pm.hook.snakesim_default_assembly()


def _snake(name: str) -> str:
    out = []
    for i, ch in enumerate(name):
        if ch.isupper() and i and not name[i - 1].isupper():
            out.append("_")
        out.append(ch.lower())
    return "".join(out)


def make_plugin_manager(load_entry_points: bool = True) -> pluggy.PluginManager:
    pm = pluggy.PluginManager("snakesim")
    pm.add_hookspecs(hookspecs)
    for modname in BUILTIN_PLUGINS:
        pm.register(importlib.import_module(modname), name=modname)
    if load_entry_points:
        pm.load_setuptools_entrypoints(ENTRY_POINT_GROUP)
    pm.check_pending()
    return pm


def build_registry(load_entry_points: bool = True) -> Registry:
    pm = make_plugin_manager(load_entry_points)
    reg = Registry(pm)
    pm.hook.snakesim_register_components(registry=reg)
    pm.hook.snakesim_register_integrators(registry=reg)
    return reg


@lru_cache(maxsize=1)
def default_registry() -> Registry:
    """The process-wide registry (built-ins plus installed plugins)."""
    return build_registry()
