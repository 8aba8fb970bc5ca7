"""Fixtures for tests/terrain; the helpers live in surface_checks.py (a unique module name, so
other test folders' conftest.py files cannot shadow them)."""

from surface_checks import *  # noqa: F401,F403  (fixtures are found in this module)
