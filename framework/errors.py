"""Errors a user can act on: each names where the problem is and what would be valid."""


class SnakesimError(Exception):
    """Base of every user-facing error; the CLI prints it without a traceback."""


class ConfigError(SnakesimError):
    """A YAML file, config file or ``--set`` override is wrong.

    ``where`` is ``file:line`` (or ``--set``) and ``key`` the dotted key path.
    """

    def __init__(self, message: str, where: str | None = None, key: str | None = None):
        self.where, self.key, self.detail = where, key, message
        prefix = ""
        if where:
            prefix += f"{where}: "
        if key:
            prefix += f"{key}: "
        super().__init__(prefix + message)


class BuildError(SnakesimError):
    """The assembly cannot be compiled into a plan (wiring, shapes, units, loops)."""


class RegistryError(SnakesimError):
    """Unknown or duplicate component / integrator names."""
