"""Fixtures for tests/multibody; the helpers live in snake_models.py (a unique module name, so
other test folders' conftest.py files cannot shadow them)."""

from snake_models import *  # noqa: F401,F403  (fixtures are found in this module)
