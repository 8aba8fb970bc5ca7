"""Component and integrator registry, filled through pluggy hooks.

Set-up follows pytest's order: create the manager, add hookspecs, register the
built-in plugins, load third-party entry points, then ask every plugin to
register. Built-ins enter exactly as a third party does: they are entry points
of the ``snakesim`` group (pyproject.toml), distinguished only by belonging to
the ``snakesim`` distribution, and use the same hooks.

A third-party plugin that fails (to import, to register with pluggy, or in its
registration hooks) is reported by name on stderr and left out; the rest load. Two
plugins registering one component or integrator name is an error only where that name
is used, and the error names both.
"""

from __future__ import annotations

import difflib
import sys
from functools import lru_cache
from importlib.metadata import entry_points

import pluggy

from . import hookspecs
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
        #: terrain kind name (the ``kind:`` of terrain YAML) -> TerrainKind, in registration order
        self.terrain_kinds: dict[str, object] = {}
        #: robot design name (the multibody's ``design:``) -> RobotDesign, in registration order
        self.robot_designs: dict[str, object] = {}
        #: ray-casting back end name (sensor_scene's ``ray_caster``) -> RayCasterBackend
        self.ray_casters: dict[str, object] = {}
        self.origins: dict[str, str] = {}
        self.pm = plugin_manager
        #: name -> the clashing registrations ("plugin: module.Class"), for names two plugins registered
        self.clashes: dict[str, list[str]] = {}
        #: the plugin whose registration hook is running (None: a direct call, which raises on a clash)
        self.current_plugin: str | None = None

    def _clash(self, kind: str, table: dict, name: str, cls) -> None:
        old = table[name]
        first = f"{self.origins.get(f'{kind}:{name}', '?')}: {old.__module__}.{old.__qualname__}"
        second = f"{self.current_plugin or '?'}: {cls.__module__}.{cls.__qualname__}"
        if self.current_plugin is None:
            raise RegistryError(f"{kind} '{name}' registered twice: {old.__module__}.{old.__qualname__} "
                                f"and {cls.__module__}.{cls.__qualname__}")
        self.clashes[f"{kind}:{name}"] = [first, second]
        del table[name]              # used anywhere, the name is an error naming both

    # -- filled by hooks --------------------------------------------------------
    def add_component(self, cls: type[Component], name: str | None = None) -> None:
        from .component import Component     # here, not at the top: the CLI's help needs no numpy

        if not (isinstance(cls, type) and issubclass(cls, Component)):
            raise RegistryError(f"{cls!r} is not a snakesim Component subclass")
        name = name or cls.type_name or _snake(cls.__name__)
        if f"component type:{name}" in self.clashes:
            self.clashes[f"component type:{name}"].append(f"{self.current_plugin}: {cls.__module__}.{cls.__qualname__}")
            return
        if name in self.components and self.components[name] is not cls:
            self._clash("component type", self.components, name, cls)
            return
        if not cls.type_name:
            cls.type_name = name
        self.components[name] = cls
        self.origins[f"component type:{name}"] = self.current_plugin or "?"

    def add_integrator(self, cls: type, name: str | None = None) -> None:
        name = name or cls.name
        if f"integrator:{name}" in self.clashes:
            return
        if name in self.integrators and self.integrators[name] is not cls:
            self._clash("integrator", self.integrators, name, cls)
            return
        self.integrators[name] = cls
        self.origins[f"integrator:{name}"] = self.current_plugin or "?"

    def add_terrain_kind(self, kind) -> None:
        """A ``TerrainKind`` (snakesim.components.terrain.kinds): its ``name`` is the ``kind:`` value."""
        from snakesim.components.terrain.kinds import TerrainKind

        self._add_named(self.terrain_kinds, "terrain kind", kind, TerrainKind,
                        lambda k: f"{k.terrain.__module__}.{k.terrain.__qualname__}")

    def add_robot_design(self, design) -> None:
        """A ``RobotDesign`` (snakesim.robots.registration): its ``name`` is the multibody's ``design:``."""
        from snakesim.robots.registration import RobotDesign

        self._add_named(self.robot_designs, "robot design", design, RobotDesign,
                        lambda d: getattr(d.build, "__module__", "?"))

    def add_ray_caster(self, backend) -> None:
        """A ``RayCasterBackend`` (snakesim.components.perception.ray_casting): its ``name`` is the value
        of sensor_scene's ``ray_caster``."""
        from snakesim.components.perception.ray_casting import RayCasterBackend

        self._add_named(self.ray_casters, "ray caster", backend, RayCasterBackend,
                        lambda b: getattr(b.world, "__module__", "?"))

    def _add_named(self, table: dict, label: str, item, cls: type, source) -> None:
        """Register ``item`` (an instance of ``cls``) under ``item.name`` in ``table``. Two plugins giving one
        name leave neither (the name raises where used, naming both: :meth:`_clashed`); outside a plugin's
        registration a second one is an error at once. ``source(item)`` says where an item comes from."""
        if not isinstance(item, cls):
            raise RegistryError(f"{item!r} is not a snakesim {cls.__name__}")
        name, key = item.name, f"{label}:{item.name}"
        where = f"{self.current_plugin or '?'}: {source(item)}"
        if key in self.clashes:
            self.clashes[key].append(where)
            return
        if name in table and table[name] is not item:
            first = f"{self.origins.get(key, '?')}: {source(table[name])}"
            if self.current_plugin is None:
                raise RegistryError(f"{label} '{name}' registered twice: {first} and {where}")
            self.clashes[key] = [first, where]
            del table[name]
            return
        table[name] = item
        self.origins[key] = self.current_plugin or "?"

    def builtins_first(self, table: dict, label: str) -> dict:
        """``table`` (name -> registered item) with the built-in plugins' entries first, in registration
        order (the order error messages list them in)."""
        builtin = builtin_plugin_names()
        first = [n for n in table if self.origins.get(f"{label}:{n}") in builtin]
        return {n: table[n] for n in first + [n for n in table if n not in first]}

    def _clashed(self, kind: str, name: str) -> None:
        both = self.clashes.get(f"{kind}:{name}")
        if both:
            raise RegistryError(f"{kind} '{name}' is registered by more than one plugin ({'; '.join(both)}): "
                                "the name is ambiguous; uninstall or rename one of them")

    # -- look-ups -----------------------------------------------------------------
    def _look_up(self, kind: str, table: dict, name: str, listing) -> type:
        """``table[name]``; an ambiguous name (:meth:`_clashed`) or an unknown one (with the close names and
        ``listing(table)``, where to find the rest) raises, naming the ``kind``."""
        self._clashed(kind, name)
        try:
            return table[name]
        except KeyError:
            raise RegistryError(f"unknown {kind} '{name}'{_close(name, table)}{listing(table)}") from None

    def component(self, name: str) -> type[Component]:
        return self._look_up("component type", self.components, name,
                             lambda t: f" (`snakesim components` lists all {len(t)})")

    def integrator(self, name: str) -> type:
        return self._look_up("integrator", self.integrators, name, lambda t: f"; valid: {', '.join(sorted(t))}")

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
        if _is_builtin(ep):
            pm.register(ep.load(), name=name)
            continue
        try:
            pm.register(ep.load(), name=name)
        except Exception as e:       # noqa: BLE001 -- any failure of a third party's code
            _broken_plugin(name, f"failed to load ({ep.value})", e)
    try:
        pm.check_pending()
    except pluggy.PluginValidationError as e:
        bad = getattr(e, "plugin", None)
        bad_name = pm.get_name(bad) if bad is not None else "?"
        if bad is None or bad_name in {ep.name for ep in eps if _is_builtin(ep)}:
            raise
        pm.unregister(bad)
        _broken_plugin(bad_name, "implements a hook snakesim does not have", e)
        pm.check_pending()
    return pm


#: third-party plugins reported broken in this process (each is reported once)
BROKEN_PLUGINS: dict[str, str] = {}


def _broken_plugin(name: str, what: str, error: BaseException) -> None:
    message = f"plugin '{name}' {what}: {type(error).__name__}: {error}"
    if name not in BROKEN_PLUGINS:
        print(f"snakesim: warning: {message}; going on without it", file=sys.stderr)
    BROKEN_PLUGINS[name] = message


@lru_cache(maxsize=1)
def builtin_plugin_names() -> frozenset:
    """The names the built-in plugins are registered under (their entry points' names)."""
    return frozenset(ep.name for ep in entry_points(group=ENTRY_POINT_GROUP) if _is_builtin(ep))


def _register_each(pm: pluggy.PluginManager, hook_name: str, reg: Registry) -> None:
    """Call one registration hook plugin by plugin (pluggy's order), so a third-party plugin that
    raises is reported by name and left out while the others register."""
    builtins = {ep.name for ep in entry_points(group=ENTRY_POINT_GROUP) if _is_builtin(ep)}
    for impl in reversed(getattr(pm.hook, hook_name).get_hookimpls()):
        reg.current_plugin = impl.plugin_name
        try:
            impl.function(**{a: reg for a in impl.argnames})
        except Exception as e:       # noqa: BLE001
            if impl.plugin_name in builtins:
                raise
            _broken_plugin(impl.plugin_name, f"failed in {hook_name}", e)
        finally:
            reg.current_plugin = None


def build_registry(load_entry_points: bool = True) -> Registry:
    pm = make_plugin_manager(load_entry_points)
    reg = Registry(pm)
    _register_each(pm, "snakesim_register_components", reg)
    _register_each(pm, "snakesim_register_integrators", reg)
    _register_each(pm, "snakesim_register_terrain_kinds", reg)
    _register_each(pm, "snakesim_register_robot_designs", reg)
    _register_each(pm, "snakesim_register_ray_casters", reg)
    return reg


def _only(hook_name: str) -> Registry:
    """A registry holding only what one registration hook gives (built-ins plus installed plugins): what
    terrain loading, robot building and sensor_scene read, without importing every component. Clashing
    names raise where used."""
    pm = make_plugin_manager()
    reg = Registry(pm)
    _register_each(pm, hook_name, reg)
    return reg


@lru_cache(maxsize=1)
def default_robot_designs() -> Registry:
    return _only("snakesim_register_robot_designs")


@lru_cache(maxsize=1)
def default_terrain_kinds() -> Registry:
    return _only("snakesim_register_terrain_kinds")


@lru_cache(maxsize=1)
def default_ray_casters() -> Registry:
    return _only("snakesim_register_ray_casters")


@lru_cache(maxsize=1)
def default_registry() -> Registry:
    """The process-wide registry (built-ins plus installed plugins)."""
    return build_registry()
