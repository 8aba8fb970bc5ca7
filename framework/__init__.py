"""snakesim.framework: generic dataflow simulation.

Ports, components, registry, assemblies, compiled scheduler, integrators and
the CLI core. Knows nothing about snakes, Pinocchio or terrain: the
pendulum and mass-spring examples run through exactly the same machinery.
"""

from .binding import Cell
from .component import Component, ContinuousState, Params
from .errors import BuildError, ConfigError, RegistryError, SnakesimError
from .harness import Harness
from .hookspecs import hookimpl
from .ports import Input, Output
from .resources import Provides, Uses

__all__ = ["Cell", "Component", "ContinuousState", "Params", "Input", "Output", "Uses", "Provides", "Harness", "hookimpl",
           "SnakesimError", "ConfigError", "BuildError", "RegistryError"]
