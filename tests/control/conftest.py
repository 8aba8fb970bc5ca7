"""Scene runner fixtures for the control tests."""

from __future__ import annotations


import pytest

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework.registry import build_registry


@pytest.fixture(scope="session")
def registry():
    return build_registry(load_entry_points=False)


@pytest.fixture(scope="module")
def mini():
    """MiniEELS 1.0, 10 modules: the helical gait's robot."""
    return RobotModel.load(design="mini-eels-1.0", modules=10)
