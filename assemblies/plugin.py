"""Makes this folder the built-in scene library and names the default scene."""

from importlib.resources import files

from snakesim.framework import hookimpl

#: `snakesim run` with no ASSEMBLY runs this: EELS 1.0's 45 s crescent screw traverse
#: (paper 4.2); the pendulum tutorial stays available by name
DEFAULT_SCENE = "surface-screw-traverse"


@hookimpl
def snakesim_assembly_paths():
    return [files("snakesim.assemblies")]


@hookimpl
def snakesim_default_assembly():
    return DEFAULT_SCENE
