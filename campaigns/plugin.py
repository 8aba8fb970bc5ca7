"""The campaigns plugin: adds ``snakesim sweep`` through the public ``snakesim_add_commands`` hook.

Named by the entry point ``campaigns`` of the ``snakesim`` group (pyproject.toml),
exactly as a third-party package would add a command.
"""

from .cli import snakesim_add_commands  # noqa: F401  (hookimpl: `snakesim sweep`)
