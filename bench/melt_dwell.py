"""Critical dwell of the heated-screw climb (issue 28): how long EELS 1.5 may stand braced with its heated
screws on the ice before they have melted in too deep to climb, against the heaters' set-point and the ice
temperature. The chart a field team wants before a test.

    .venv/bin/python bench/melt_dwell.py [--quick] [--json FILE] [--png FILE] [--cost-only]

For each (set-point, ice temperature) the scene assemblies/melt-dwell-climb.yaml runs with ``dwell`` set
by bisection: a run whose outcome is success climbed (melt_climb_watch: ≥ min_climb within the window after
the dwell), a failure did not (melted in: kind ``mobility``; any other kind is flagged in the table's row). The bracket starts at [2 s, 40 s] and doubles its upper end up to
``MAX_DWELL``; bisection stops when it is narrower than ``TOL`` s. The critical dwell is reported as the
bracket's midpoint with its half-width. Ice at −5 °C: an Earth glacier, in still air (convection 10 W/(m² K),
air at the ice temperature); at −180 °C (93.15 K): Enceladus's surface, vacuum (no convection, radiation to
surroundings at the ice temperature) — but Earth's gravity (the scene's), so only the thermal side changes.

Also the thermal components' cost as a fraction of the scene's wall time (target ≤ 10 %): each thermal
component's methods (screw_heat, groove_drag, thermostat, thermocouple, melt_climb_watch, and the wrench sum
they need) timed in place over one run, against the run's own wall time.

Grids: full = set-points 10, 20, 30, 40 °C × ice −5, −180 °C, TOL 1 s; --quick = 10 and 40 °C, TOL 4 s.
Writes bench/results/melt_dwell.json and bench/results/melt_dwell.png (or the given files).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from snakesim.framework.session import load_session

SCENE = "melt-dwell-climb"
ICE = {"glacier -5 C": {"ice_temperature": 268.15, "environment_temperature": 268.15, "convection": 10.0},
       "Enceladus -180 C": {"ice_temperature": 93.15, "environment_temperature": 93.15, "convection": 0.0}}
MAX_DWELL = 320.0
RESULTS = Path(__file__).with_name("results")


def run_once(dwell: float, set_point_c: float, ice: dict) -> dict:
    sets = {"dwell": dwell, "set_point": set_point_c + 273.15, **ice}
    r = load_session(SCENE, overrides=[f"{k}={v}" for k, v in sets.items()]).run()
    s = r.summary
    heat, watch = s["reports"].get("heat", {}), s["reports"].get("watch", {})
    return {"dwell_s": dwell, "outcome": s["outcome"], "failure_kind": s["failure_kind"],
            "stop_reason": s["stop_reason"], "wall_s": s["wall_time_s"], "sim_s": s["sim_time_s"],
            "deepest_mm": watch.get("deepest_penetration_mm"), "climb_m": watch.get("climb_m"),
            "screw_temperature_C": [v["temperature_C"] for v in heat.get("screws", {}).values()]}


def critical_dwell(set_point_c: float, ice: dict, tol: float) -> dict:
    runs = []
    lo, hi = 2.0, 40.0
    first = run_once(lo, set_point_c, ice)
    runs.append(first)
    if first["outcome"] != "success":
        return {"critical_dwell_s": None, "note": f"fails already at {lo:g} s", "runs": runs}
    while True:
        r = run_once(hi, set_point_c, ice)
        runs.append(r)
        if r["outcome"] != "success":
            break
        lo, hi = hi, 2.0 * hi
        if hi > MAX_DWELL:
            return {"critical_dwell_s": None, "note": f"climbs after every dwell up to {lo:g} s", "runs": runs}
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        r = run_once(mid, set_point_c, ice)
        runs.append(r)
        lo, hi = (mid, hi) if r["outcome"] == "success" else (lo, mid)
    return {"critical_dwell_s": 0.5 * (lo + hi), "bracket_s": [lo, hi], "runs": runs}


def thermal_cost() -> dict:
    """Wall time in the thermal components' methods over one short-dwell run, against the run's; the wrench
    sum the groove wall needs (an existing junction, tethers/wrench_sum.py) is counted apart."""
    from snakesim.components.tethers.wrench_sum import WrenchSum
    from snakesim.components.thermal import THERMAL

    spent: dict[str, float] = {}
    patched = []
    for cls in (*THERMAL, WrenchSum):
        spent[cls.type_name] = 0.0
        for name in ("output", "update", "port_jacobian"):
            if name in vars(cls):
                orig = vars(cls)[name]

                def timed(*a, _f=orig, _k=cls.type_name, **k):
                    t0 = time.perf_counter()
                    try:
                        return _f(*a, **k)
                    finally:
                        spent[_k] += time.perf_counter() - t0
                setattr(cls, name, timed)
                patched.append((cls, name, orig))
    try:
        load_session(SCENE, overrides=["dwell=1"], sim_overrides={"duration": 0.2}).run()     # warm-up
        for k in spent:
            spent[k] = 0.0
        r = run_once(5.0, 20.0, ICE["glacier -5 C"])
    finally:
        for cls, name, orig in patched:
            setattr(cls, name, orig)
    thermal = sum(v for k, v in spent.items() if k != "wrench_sum")
    return {"scene_wall_s": r["wall_s"], "scene_sim_s": r["sim_s"], "steps": round(r["sim_s"] / 0.01),
            "per_component_s": spent, "thermal_s": thermal, "fraction": thermal / r["wall_s"],
            "with_wrench_sum_fraction": (thermal + spent["wrench_sum"]) / r["wall_s"]}


def plot(table: list[dict], path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for ice, colour in zip(ICE, ("tab:blue", "tab:orange")):
        rows = [r for r in table if r["ice"] == ice and r["critical_dwell_s"] is not None]
        if rows:
            ax.errorbar([r["set_point_C"] for r in rows], [r["critical_dwell_s"] for r in rows],
                        yerr=[0.5 * (r["bracket_s"][1] - r["bracket_s"][0]) for r in rows], marker="o",
                        capsize=3, color=colour, label=f"ice {ice}")
        above = [r for r in table if r["ice"] == ice and r["critical_dwell_s"] is None
                 and r["runs"][0]["outcome"] == "success"]      # climbed after every dwell tried
        for r in above:
            longest = max(x["dwell_s"] for x in r["runs"])
            ax.plot([r["set_point_C"]], [longest], marker="^", color=colour, linestyle="none")
            ax.annotate(f"climbs after {longest:g} s", (r["set_point_C"], longest), textcoords="offset points",
                        xytext=(6, -4), fontsize=8, color=colour)
    ax.set_xlabel("heater set-point (°C)")
    ax.set_ylabel("critical dwell (s)")
    ax.set_title("EELS 1.5 braced climb: longest dwell that still climbs")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="10 and 40 °C only, 4 s bisection tolerance")
    ap.add_argument("--cost-only", action="store_true", help="only the thermal components' cost")
    ap.add_argument("--json", type=Path, default=RESULTS / "melt_dwell.json")
    ap.add_argument("--png", type=Path, default=RESULTS / "melt_dwell.png")
    a = ap.parse_args(argv)
    cost = thermal_cost()
    print(f"thermal components: {1e3 * cost['thermal_s']:.1f} ms of a {cost['scene_wall_s']:.2f} s run "
          f"({cost['steps']} steps): {100 * cost['fraction']:.1f} % of the scene's step (target <= 10 %); "
          f"with the wrench sum the groove wall needs: {100 * cost['with_wrench_sum_fraction']:.1f} %")
    print("  " + ", ".join(f"{k} {1e3 * v:.1f} ms" for k, v in cost["per_component_s"].items()))
    out = {"scene": SCENE, "thermal_cost": cost}
    if not a.cost_only:
        set_points, tol = ((10.0, 40.0), 4.0) if a.quick else ((10.0, 20.0, 30.0, 40.0), 1.0)
        table, t0 = [], time.perf_counter()
        print(f"{'ice':>18} {'set-point':>10} {'critical dwell':>16} {'runs':>5} {'wall':>7}")
        for ice, sets in ICE.items():
            for sp in set_points:
                w0 = time.perf_counter()
                r = critical_dwell(sp, sets, tol)
                row = {"ice": ice, "set_point_C": sp, **r, "wall_s": time.perf_counter() - w0}
                table.append(row)
                cd = (f"{r['critical_dwell_s']:.1f} ± {0.5 * (r['bracket_s'][1] - r['bracket_s'][0]):.1f} s"
                      if r["critical_dwell_s"] is not None else r["note"])
                other = sorted({x["failure_kind"] for x in r["runs"] if x["outcome"] != "success"} - {"mobility"})
                print(f"{ice:>18} {sp:>8.0f} C {cd:>16} {len(r['runs']):>5} {row['wall_s']:>6.0f}s"
                      + (f"  (failures other than mobility: {', '.join(other)})" if other else ""), flush=True)
        out.update({"grid": "quick" if a.quick else "full", "tolerance_s": tol, "table": table,
                    "sweep_wall_s": time.perf_counter() - t0})
        plot(table, a.png)
        print(f"wrote {a.png}")
    a.json.parent.mkdir(parents=True, exist_ok=True)
    a.json.write_text(json.dumps(out, indent=2) + "\n")
    print(f"wrote {a.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
