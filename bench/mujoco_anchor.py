"""MuJoCo's speed on a comparable screw snake, measured in this process (../shared/peers/mujoco_snake.py),
so a bench can print snakesim's real-time factor as a ratio of MuJoCo's from the same run.

    from mujoco_anchor import mujoco_rtf
    rtf = mujoco_rtf(modules=10, dt=1e-3)       # None when mujoco or the peer script is missing
"""

from __future__ import annotations

import importlib.util
import statistics
from pathlib import Path

PEER = Path(__file__).resolve().parents[2] / "shared" / "peers" / "mujoco_snake.py"


def mujoco_rtf(modules: int = 10, dt: float = 1e-3, integrator: str = "Euler", duration: float = 5.0,
               repeats: int = 3) -> float | None:
    """Median real-time factor of MuJoCo's screw snake (the peer script), or None if unavailable."""
    if not PEER.exists() or importlib.util.find_spec("mujoco") is None:
        return None
    spec = importlib.util.spec_from_file_location("mujoco_snake", PEER)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    rows = [mod.real_time_factor(modules, dt, integrator, duration) for _ in range(repeats)]
    return statistics.median(r["real_time_factor"] for r in rows)
