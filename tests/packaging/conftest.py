"""Fixtures of the packaging tests (helpers live in packaging_helpers.py)."""

import shutil

import pytest


@pytest.fixture
def scratch(tmp_path):
    """A temporary folder removed afterwards even when the test passes (venvs are big)."""
    yield tmp_path
    shutil.rmtree(tmp_path, ignore_errors=True)
