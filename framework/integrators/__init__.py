"""Integrators, one scheme per module, registered through ``snakesim_register_integrators``."""
