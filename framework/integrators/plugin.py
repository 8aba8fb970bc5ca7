"""Registers the built-in integrators through the public hook."""

from ..hookspecs import hookimpl


@hookimpl
def snakesim_register_integrators(registry):
    # imported here, not at load: loading the plugin (as `snakesim --help` does) needs no scipy
    from .dopri5 import Dopri5
    from .rk4 import RK4
    from .rosenbrock2 import Rosenbrock2
    from .rosenbrock_w import RosenbrockW
    from .semi_implicit_euler import SemiImplicitEuler

    for cls in (SemiImplicitEuler, RK4, Dopri5, Rosenbrock2, RosenbrockW):
        registry.add_integrator(cls)
