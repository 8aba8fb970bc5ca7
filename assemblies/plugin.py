"""Makes this folder the built-in scene library and names the default scene."""

from importlib.resources import files

from snakesim.framework import hookimpl

#: `snakesim run` with no ASSEMBLY runs this; it becomes the surface screw
#: traverse once the robot scenes exist
DEFAULT_SCENE = "pendulum"


@hookimpl
def snakesim_assembly_paths():
    return [files("snakesim.assemblies")]


@hookimpl
def snakesim_default_assembly():
    return DEFAULT_SCENE
