"""Tethers (paper 2.2.6): spring-damper ropes to world anchors, and a per-link wrench sum."""

from .tether import Tethers, TetherSpec
from .wrench_sum import WrenchSum

__all__ = ["TetherSpec", "Tethers", "WrenchSum"]
