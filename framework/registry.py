"""Component and integrator registry, filled through pluggy hooks.

Set-up follows pytest's order: create the manager, add hookspecs, register the
built-in plugins, load third-party entry points, then ask every plugin to
register. Built-ins enter exactly as a third party does: they are entry points
of the ``snakesim`` group (pyproject.toml), distinguished only by belonging to
the ``snakesim`` distribution, and use the same hooks.
"""

from __future__ import annotations

import difflib
from functools import lru_cache
from importlib.metadata import entry_points

import pluggy

from . import hookspecs
from .component import Component
from .errors import RegistryError

ENTRY_POINT_GROUP = "snakesim"
#: the distribution whose entry points are the built-in plugins
BUILTIN_DISTRIBUTION = "snakesim"


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

    def classes_in(self, resolved):
        """(name, spec, class) of each component of a resolved configuration whose type is registered;
        unknown types are skipped here (the build reports them, naming file and key). For run options
        that add components by what the scene's classes declare (``--viz``, ``--ros2``)."""
        for name, spec in resolved.components.items():
            if spec.type in self.components:
                yield name, spec, self.components[spec.type]

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


def _is_builtin(ep) -> bool:
    dist = getattr(ep, "dist", None)
    return dist is not None and dist.name == BUILTIN_DISTRIBUTION


def make_plugin_manager(load_entry_points: bool = True) -> pluggy.PluginManager:
    """Built-in entry points first, then (``load_entry_points``) every third-party one."""
    pm = pluggy.PluginManager("snakesim")
    pm.add_hookspecs(hookspecs)
    eps = sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda ep: not _is_builtin(ep))
    if not any(_is_builtin(ep) for ep in eps):
        raise RegistryError(f"no built-in '{ENTRY_POINT_GROUP}' entry points found: snakesim is not installed "
                            "(pip install -e . from the repository root)")
    for ep in eps:
        name = ep.name if _is_builtin(ep) else f"{ep.dist.name if ep.dist else '?'}:{ep.name}"
        if not (_is_builtin(ep) or load_entry_points) or pm.get_plugin(name) is not None:
            continue
        pm.register(ep.load(), name=name)
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
