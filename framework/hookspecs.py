"""The hooks a snakesim plugin may implement (entry-point group ``snakesim``)."""

import pluggy

hookspec = pluggy.HookspecMarker("snakesim")
hookimpl = pluggy.HookimplMarker("snakesim")


@hookspec
def snakesim_register_components(registry):
    """Add component classes with ``registry.add_component(cls, name=None)``."""


@hookspec
def snakesim_register_integrators(registry):
    """Add integrator classes with ``registry.add_integrator(cls, name=None)``."""


@hookspec
def snakesim_register_terrain_kinds(registry):
    """Add terrain kinds with ``registry.add_terrain_kind(kind)``: a
    ``snakesim.components.terrain.TerrainKind`` (the ``kind:`` value of terrain YAML, its pydantic spec
    model, the factory that builds its Terrain). Every consumer (contact, viewer, sensors, placement) reads
    the terrain through the Terrain class's own methods, so nothing else is registered."""


@hookspec
def snakesim_register_robot_designs(registry):
    """Add robot designs with ``registry.add_robot_design(design)``: a ``snakesim.robots.RobotDesign``
    (the ``design:`` value of a multibody, a builder returning the URDF and its metadata sidecar
    mapping, defaults such as the module count)."""


@hookspec
def snakesim_register_ray_casters(registry):
    """Add ray-casting back ends with ``registry.add_ray_caster(backend)``: a
    ``snakesim.components.perception.ray_casting.RayCasterBackend`` (the name ``sensor_scene``'s
    ``ray_caster`` parameter selects, and the builders of its static scenes and of the ``RayCaster``
    the sensors cast into at each instant)."""


@hookspec
def snakesim_assembly_paths():
    """Return folders (paths or importlib Traversables) holding assembly YAML files."""


@hookspec(firstresult=True)
def snakesim_default_assembly():
    """Return the name of the scene ``run`` and ``check`` use when none is given."""


@hookspec
def snakesim_add_commands(cli):
    """Add click commands to the ``snakesim`` command group."""


@hookspec
def snakesim_cli_shorthands():
    """Return ``(option, key.path, help)`` triples: ``--option V`` means ``--set key.path=V``."""


@hookspec
def snakesim_run_options():
    """Return ``(click.Option, apply)`` pairs for ``run``/``check``.

    ``apply(resolved, value)`` edits the resolved configuration before it is
    built when the option is given (e.g. ``--viz`` adds a viewer sink). An
    ``apply`` with the attribute ``adds_sink = True`` runs after every other
    given option, so a sink wires the components the others added (``--viz``
    shows the sensors ``--lidar`` adds).
    """
