"""The first run says it compiles (framework/warm_up.py kernels_cached): with numba's cache empty the CLI
prints the notice before building; with it filled by this test session's runs it does not."""

from __future__ import annotations

import os
import subprocess
import sys


def run_pendulum(env):
    return subprocess.run([sys.executable, "-c", "from snakesim.framework.cli import main; main()", "run",
                           "pendulum", "--duration", "0.05"], capture_output=True, text=True, env=env, timeout=300)


def test_an_empty_kernel_cache_is_announced_and_a_filled_one_is_not(tmp_path):
    cold = run_pendulum({**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "empty")})
    assert cold.returncode == 0 and cold.stderr.startswith("compiling kernels, once: about"), cold.stderr[:500]
    filled = tmp_path / "filled" / "x"
    filled.mkdir(parents=True)
    (filled / "kernel.f-1.py311.nbi").write_bytes(b"")        # what numba leaves: an index per kernel
    warm = run_pendulum({**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "filled")})
    assert warm.returncode == 0 and "compiling kernels" not in warm.stderr, warm.stderr[:500]
