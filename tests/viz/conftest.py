"""Fixtures for tests/viz; the helpers live in viz_scenes.py (a unique module name, so
other test folders' conftest.py files cannot shadow them)."""

from viz_scenes import *  # noqa: F401,F403  (fixtures are found in this module)
