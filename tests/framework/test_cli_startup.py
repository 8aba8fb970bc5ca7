"""`snakesim --help` starts without the heavy imports (bench/cli_startup.py measures the time).

Tests never assert wall time; they assert the cause of a slow start: the top-level help must list
every command, plugin commands included, without importing numpy, pydantic or a component module.
"""

from __future__ import annotations

import subprocess
import sys

PROBE = """
import sys
from snakesim.framework.cli import main
sys.argv[1:] = ["--help"]
try:
    main()
except SystemExit:
    pass
heavy = sorted(m for m in ("numpy", "pydantic", "scipy", "snakesim.components.multibody",
                           "snakesim.framework.component") if m in sys.modules)
print("HEAVY:", ",".join(heavy))
"""


def test_top_level_help_lists_every_command_without_heavy_imports():
    proc = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    for command in ("run", "check", "graph", "components", "replay", "fit-friction", "robot"):
        assert f"  {command} " in proc.stdout, f"{command} missing from `snakesim --help`:\n{proc.stdout}"
    assert proc.stdout.strip().endswith("HEAVY:"), proc.stdout.splitlines()[-1]
