"""snakesim.framework: generic dataflow simulation.

Ports, components, registry, assemblies, compiled scheduler, integrators and
the CLI core. Knows nothing about snakes, Pinocchio or terrain: the
pendulum and mass-spring examples run through exactly the same machinery.

The public names load on first use (PEP 562): ``snakesim --help`` and a
plugin module that only needs ``hookimpl`` do not pay for numpy and pydantic.
"""

from importlib import import_module

from .hookspecs import hookimpl

_WHERE = {"Cell": "binding", "Component": "component", "ContinuousState": "component", "Params": "component",
          "BuildError": "errors", "ConfigError": "errors", "RegistryError": "errors", "SnakesimError": "errors",
          "Harness": "harness", "Input": "ports", "Output": "ports", "Provides": "resources", "Uses": "resources",
          "Builder": "builder", "Simulation": "simulation", "load": "simulation"}

__all__ = ["Cell", "Component", "ContinuousState", "Params", "Input", "Output", "Uses", "Provides", "Harness", "hookimpl",
           "Builder", "Simulation", "load", "SnakesimError", "ConfigError", "BuildError", "RegistryError"]


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f".{_WHERE[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
