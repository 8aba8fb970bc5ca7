"""Fixtures shared by every test folder."""

from __future__ import annotations

import textwrap

import pytest

from snakesim.framework.session import load_session


@pytest.fixture
def run_scene(tmp_path, registry):
    """run_scene(yaml_text, **files) -> (session, RunResult); files are written next to the scene first.

    Uses the ``registry`` fixture of the test's own folder (its test components).
    """

    def run(text: str, **files: str):
        for name, content in files.items():
            (tmp_path / name).write_text(content)
        path = tmp_path / "scene.yaml"
        path.write_text(textwrap.dedent(text).lstrip("\n"))
        session = load_session(path, registry=registry)
        return session, session.run()

    return run
