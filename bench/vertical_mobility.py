"""Vertical mobility scenes at their production step: real-time factor and the field test's evaluation.

    .venv/bin/python bench/vertical_mobility.py [--json FILE]

One line per scene: the run's real-time factor (simulated / wall s, one warm-up run first so numba's
compilation is not counted), its stop, and the evaluation's contact / hold / distance / failure
(components/monitors/vertical_mobility.py, summary.json reports/evaluation).
"""

from __future__ import annotations

import json
import sys

from snakesim.framework.session import load_session

SCENES = ["walls-brace-climb", "walls-brace-climb-fail", "parallel-walls-climb"]


def measure(scene: str) -> dict:
    load_session(scene, sim_overrides={"duration": 0.2}).run()            # warm-up: JIT compilation
    s = load_session(scene)
    r = s.run()
    sm, ev = r.summary, r.summary.get("reports", {}).get("evaluation", {})
    return {"scene": scene, "integrator": s.integrator.name, "dt_s": sm["dt_s"], "sim_time_s": sm["sim_time_s"],
            "wall_time_s": sm["wall_time_s"], "real_time_factor": sm["real_time_factor"],
            "stop_reason": sm["stop_reason"], "evaluation": ev}


def main(argv):
    rows = [measure(sc) for sc in SCENES]
    print(f"{'scene':26s} {'integrator':12s} {'dt ms':>6s} {'sim s':>6s} {'RTF':>6s}  hold s  down m  stop")
    for r in rows:
        ev = r["evaluation"]
        print(f"{r['scene']:26s} {r['integrator']:12s} {1e3 * r['dt_s']:6.3g} {r['sim_time_s']:6.3g} "
              f"{r['real_time_factor']:6.3g}  {ev.get('hold', {}).get('longest_s', float('nan')):6.3g}  "
              f"{ev.get('vertical_distance', {}).get('down_m', float('nan')):6.3g}  {r['stop_reason']}")
    if "--json" in argv:
        with open(argv[argv.index("--json") + 1], "w") as f:
            json.dump(rows, f, indent=2, default=float)


if __name__ == "__main__":
    main(sys.argv[1:])
