"""Start-up time of the ``snakesim`` command: ``snakesim --help`` and ``snakesim COMMAND --help``.

Each command runs in a fresh interpreter (the console script the install wrote, beside this
interpreter), best and median of ``--repeats`` wall times. Goal: ``snakesim --help`` under 0.5 s
(issue 18): the top-level help imports neither numpy nor a component; a command's own help loads
what that command needs. ``python -X importtime -c "from snakesim.framework.cli import main; main()"
--help`` says where the time goes.

    .venv/bin/python bench/cli_startup.py [--repeats 7] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

SNAKESIM = Path(sys.executable).parent / "snakesim"
CASES = (["--help"], ["robot", "--help"], ["run", "--help"])
GOAL_S = 0.5


def wall_times(args: list[str], repeats: int) -> list[float]:
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run([str(SNAKESIM), *args], check=True, stdout=subprocess.DEVNULL)
        out.append(time.perf_counter() - t0)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--json", type=Path, help="write the figures here")
    args = ap.parse_args(argv)
    if not SNAKESIM.exists():
        ap.error(f"{SNAKESIM} not found: install snakesim into this environment (pip install -e .)")
    rows = []
    print(f"{'command':<28}{'best s':>9}{'median s':>10}")
    for case in CASES:
        times = wall_times(case, args.repeats)
        row = {"command": "snakesim " + " ".join(case), "best_s": min(times), "median_s": statistics.median(times)}
        rows.append(row)
        print(f"{row['command']:<28}{row['best_s']:>9.3f}{row['median_s']:>10.3f}")
    top = rows[0]["median_s"]
    print(f"goal: `snakesim --help` < {GOAL_S} s: {'met' if top < GOAL_S else 'NOT met'} (median {top:.3f} s)")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"goal_s": GOAL_S, "rows": rows}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
