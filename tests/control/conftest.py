"""Scene runner fixtures for the control tests."""

from __future__ import annotations


import pytest

from snakesim.framework.registry import build_registry


@pytest.fixture(scope="session")
def registry():
    return build_registry(load_entry_points=False)


