"""Scene runner fixtures for the control tests."""

from __future__ import annotations

import textwrap

import pytest

from snakesim.framework.registry import build_registry
from snakesim.framework.session import load_session


@pytest.fixture(scope="session")
def registry():
    return build_registry(load_entry_points=False)


@pytest.fixture
def run_scene(tmp_path, registry):
    """run_scene(yaml_text, **files) -> (session, RunResult); files are written to tmp_path first."""

    def run(text: str, **files: str):
        for name, content in files.items():
            (tmp_path / name).write_text(content)
        path = tmp_path / "scene.yaml"
        path.write_text(textwrap.dedent(text).lstrip("\n"))
        session = load_session(path, registry=registry)
        return session, session.run()

    return run
