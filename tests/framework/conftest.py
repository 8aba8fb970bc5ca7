"""Shared fixtures for the framework tests: a registry with the test-only components of
framework_components.py (they live in the tests, not in the product), and YAML scenes written and loaded."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from framework_components import TEST_COMPONENTS
from snakesim.framework.registry import build_registry
from snakesim.framework.session import load_session


@pytest.fixture(scope="session")
def registry():
    """Built-ins (no third-party entry points) plus the test components (framework_components.py)."""
    reg = build_registry(load_entry_points=False)
    for cls in TEST_COMPONENTS:
        reg.add_component(cls)
    return reg


@pytest.fixture
def write_yaml(tmp_path):
    """write_yaml(text, name="scene.yaml") -> Path; dedents the text."""

    def write(text: str, name: str = "scene.yaml") -> Path:
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text).lstrip("\n"))
        return path

    return write


@pytest.fixture
def scene(write_yaml, registry):
    """scene(text, **load_session kwargs) -> Session built from a YAML text."""

    def make(text: str, name: str = "scene.yaml", **kw):
        return load_session(write_yaml(text, name), registry=registry, **kw)

    return make
