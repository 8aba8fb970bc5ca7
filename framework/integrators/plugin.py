"""Registers the built-in integrators through the public hook."""

from ..hookspecs import hookimpl
from .dopri5 import Dopri5
from .rk4 import RK4
from .rosenbrock2 import Rosenbrock2
from .semi_implicit_euler import SemiImplicitEuler


@hookimpl
def snakesim_register_integrators(registry):
    for cls in (SemiImplicitEuler, RK4, Dopri5, Rosenbrock2):
        registry.add_integrator(cls)
