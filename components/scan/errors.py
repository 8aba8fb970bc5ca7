"""The error of a scan import: what is wrong with which file, and what would be valid."""

from __future__ import annotations

from snakesim.framework.errors import SnakesimError


class ScanError(SnakesimError):
    """A scan file cannot be imported; ``path`` is the file (``str(e)`` starts with it)."""

    def __init__(self, path, message: str):
        self.path, self.detail = str(path), message
        super().__init__(f"{path}: {message}")
