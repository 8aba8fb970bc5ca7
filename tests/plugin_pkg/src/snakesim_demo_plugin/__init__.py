"""snakesim-demo-plugin: a first-order low-pass filter as a third-party component."""

from .lowpass import LowPass

__all__ = ["LowPass"]
