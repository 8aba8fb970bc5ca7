"""Run monitors: mobility failure detection and climbing-test metrics (paper 4.3.1)."""

from .mobility import MobilityMonitor

__all__ = ["MobilityMonitor"]
