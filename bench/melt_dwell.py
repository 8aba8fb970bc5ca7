"""Critical dwell of the heated-screw climb (issue 28): how long EELS 1.5 may stand braced with its heated
screws on the ice before they have melted in too deep to climb, against the heaters' set-point and the ice
temperature. The chart a field team wants before a test.

    .venv/bin/python bench/melt_dwell.py [--quick] [--json FILE] [--png FILE] [--cost [--repeats N]]

For each (set-point, ice temperature) the scene assemblies/melt-dwell-climb.yaml runs with ``dwell`` set
by bisection: a run whose outcome is success climbed (melt_climb_watch: ≥ min_climb within the window after
the dwell), a failure did not (melted in: kind ``mobility``; any other kind is flagged in the table's row). The bracket starts at [2 s, 40 s] and doubles its upper end up to
``MAX_DWELL``; bisection stops when it is narrower than ``TOL`` s. The critical dwell is reported as the
bracket's midpoint with its half-width. Ice at −5 °C: an Earth glacier, in still air (convection 10 W/(m² K),
air at the ice temperature); at −180 °C (93.15 K): Enceladus's surface, vacuum (no convection, radiation to
surroundings at the ice temperature) — but Earth's gravity (the scene's), so only the thermal side changes.

Also the thermal side's cost as a fraction of the scene's step (target <= 10 %): the scene against itself with
the thermal components taken out (thermal_cost: alternating runs in one process, medians per integrator step
and per run); --cost runs only that and writes bench/results/melt_cost.json.

Grids: full = set-points 10, 20, 30, 40 °C × ice −5, −180 °C, TOL 1 s; --quick = 10 and 40 °C, TOL 4 s;
--set-points / --tolerance choose others (the cost is then measured only with --cost); --ice NAME,... some of the
ices; --scene another variant (melt-dwell-climb-ice-friction: ice on ice's friction, the brace pre-loaded).
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


def run_once(dwell: float, set_point_c: float, ice: dict, scene: str = SCENE) -> dict:
    sets = {"dwell": dwell, "set_point": set_point_c + 273.15, **ice}
    r = load_session(scene, overrides=[f"{k}={v}" for k, v in sets.items()]).run()
    s = r.summary
    heat, watch = s["reports"].get("heat", {}), s["reports"].get("watch", {})
    return {"dwell_s": dwell, "outcome": s["outcome"], "failure_kind": s["failure_kind"],
            "stop_reason": s["stop_reason"], "wall_s": s["wall_time_s"], "sim_s": s["sim_time_s"],
            "deepest_mm": watch.get("deepest_penetration_mm"), "climb_m": watch.get("climb_m"),
            "failure": watch.get("failure"), "at_failure": watch.get("at_failure"),
            "screw_temperature_C": [v["temperature_C"] for v in heat.get("screws", {}).values()]}


def critical_dwell(set_point_c: float, ice: dict, tol: float, scene: str = SCENE) -> dict:
    runs = []
    lo, hi = 2.0, 40.0
    first = run_once(lo, set_point_c, ice, scene)
    runs.append(first)
    if first["outcome"] != "success":
        return {"critical_dwell_s": None, "note": f"fails already at {lo:g} s", "runs": runs}
    while True:
        r = run_once(hi, set_point_c, ice, scene)
        runs.append(r)
        if r["outcome"] != "success":
            break
        lo, hi = hi, 2.0 * hi
        if hi > MAX_DWELL:
            return {"critical_dwell_s": None, "note": f"climbs after every dwell up to {lo:g} s", "runs": runs}
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        r = run_once(mid, set_point_c, ice, scene)
        runs.append(r)
        lo, hi = (mid, hi) if r["outcome"] == "success" else (lo, mid)
    return {"critical_dwell_s": 0.5 * (lo + hi), "bracket_s": [lo, hi], "runs": runs}


#: the scene's thermal side: removed, with its connections and records, for the "off" runs of thermal_cost
THERMAL_PARTS = ("heat", "groove", "wsum", "ice", "thermocouple", "thermostat", "watch")


def scene_without_thermal(overrides: list[str], duration: float, folder: Path) -> Path:
    """melt-dwell-climb with its thermal components taken out (the contact's wrenches straight into the
    multibody, as walls-brace-climb wires them), written as a scene file in ``folder``."""
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry
    from snakesim.framework.yaml_source import dump_yaml

    d = resolve(SCENE, search_path=default_registry().assembly_paths(), overrides=overrides,
                sim_overrides={"duration": duration}).to_dict()
    ours = lambda ref: ref.split(".")[0] in THERMAL_PARTS       # noqa: E731
    d["components"] = {k: v for k, v in d["components"].items() if k not in THERMAL_PARTS}
    kept = []
    for line in d["connections"]:
        src, targets = (x.strip() for x in line.split("->"))
        targets = [t.strip() for t in targets.split(",") if not ours(t.strip())]
        if not ours(src) and targets:
            kept.append(f"{src} -> {', '.join(targets)}")
    d["connections"] = kept + ["contact.wrenches -> robot.wrenches"]
    d["record"] = [r for r in d["record"] if not ours(r)]
    d.pop("include", None)
    path = folder / "melt-dwell-climb-no-thermal.yaml"
    path.write_text(dump_yaml(d))
    return path


def thermal_cost(repeats: int = 5, duration: float = 3.0) -> dict:
    """The thermal side's cost as a share of the scene's step: the scene (a braced hold of ``duration`` s)
    against the same scene with the thermal components taken out, run alternately in this process,
    ``repeats`` times each, timing the runs' loops (summary wall_time_s, the build apart).

    With the screws melting in, the two runs would step different physics: the walls sinking under the
    screws move the brace, and rosenbrock_w's error control takes ~2.7× the integrator steps of the rigid
    hold. So the "on" runs hold the heaters' set-point at the ice's temperature (−5 °C): every thermal
    component runs, nothing melts, the contact sees what it sees without them and both runs take the same
    steps (checked: ``same_steps``). share = (on − off) / on of the medians of the runs' loop cpu time
    (summary cpu_time_s: on a shared machine less disturbed than the wall time, also given, as is the share
    of the least cpu times). The melting hold is timed too ("melting"), for the slowdown a user sees,
    physics included."""
    import statistics
    import tempfile
    import warnings

    from snakesim.framework.session import load_session

    # the thermostat warns that a set-point at the ice's temperature melts nothing: here that is the point
    warnings.filterwarnings("ignore", message=".*will not melt into the ice")
    overrides = [f"dwell={duration + 1.0:g}"]          # the hold only
    cold = overrides + ["set_point=268.15"]            # the ice's temperature: heaters off, no melt-in
    with tempfile.TemporaryDirectory() as tmp:
        off_scene = scene_without_thermal(overrides, duration, Path(tmp))
        makers = {"on": lambda: load_session(SCENE, overrides=cold, sim_overrides={"duration": duration}),
                  "off": lambda: load_session(off_scene),
                  "melting": lambda: load_session(SCENE, overrides=overrides, sim_overrides={"duration": duration})}
        for make in makers.values():
            make().run()                                             # warm-up: compiled code, caches
        runs = {k: [] for k in makers}
        for _ in range(repeats):
            for key, make in makers.items():
                s = make().run().summary
                runs[key].append({"wall_s": s["wall_time_s"], "cpu_s": s["cpu_time_s"],
                                  "steps": s["integrator"]["steps"], "f_evals": s["integrator"]["f_evals"]})
    med = {k: {"wall_s": statistics.median(r["wall_s"] for r in v), "cpu_s": statistics.median(r["cpu_s"] for r in v),
               "least_cpu_s": min(r["cpu_s"] for r in v), "steps": statistics.median(r["steps"] for r in v)}
           for k, v in runs.items()}
    share = lambda key: (med["on"][key] - med["off"][key]) / med["on"][key]          # noqa: E731
    return {"scene": SCENE, "duration_s": duration, "repeats": repeats, "runs": runs, "medians": med,
            "same_steps": all(a["steps"] == b["steps"] for a, b in zip(runs["on"], runs["off"])),
            "fraction": share("cpu_s"), "fraction_wall": share("wall_s"), "fraction_least": share("least_cpu_s"),
            "pair_fractions": [1 - b["cpu_s"] / a["cpu_s"] for a, b in zip(runs["on"], runs["off"])],
            "melting_slowdown": med["melting"]["cpu_s"] / med["off"]["cpu_s"]}


def print_cost(cost: dict) -> None:
    print(f"thermal side's cost: {cost['scene']}, a braced hold of {cost['duration_s']:g} s, "
          f"{cost['repeats']} alternating repeats (medians)")
    print(f"{'':>26} {'cpu':>8} {'least cpu':>10} {'wall':>8} {'int. steps':>11}")
    for k, what in (("on", "thermal on (nothing melts)"), ("off", "thermal off"), ("melting", "thermal on, melting")):
        m = cost["medians"][k]
        print(f"{what:>26} {m['cpu_s']:>6.3f} s {m['least_cpu_s']:>8.3f} s {m['wall_s']:>6.3f} s {m['steps']:>11.0f}")
    print(f"thermal share of the scene's step: {100 * cost['fraction']:.1f} % of the median cpu time (target <= 10 %;"
          f" least: {100 * cost['fraction_least']:.1f} %, wall: {100 * cost['fraction_wall']:.1f} %; pairs "
          + ", ".join(f"{100 * f:.0f}" for f in cost["pair_fractions"]) + " %)"
          + ("" if cost["same_steps"] else "  WARNING: on and off took different integrator steps"))
    print(f"melting hold against the rigid one, physics included: {cost['melting_slowdown']:.2f}x the cpu time")


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
    ap.add_argument("--set-points", default=None, metavar="C,C,...",
                    help="heater set-points, °C (replaces the grid's; e.g. 20,30 to add to a --quick table)")
    ap.add_argument("--tolerance", type=float, default=None, metavar="S", help="bisection tolerance, s")
    ap.add_argument("--scene", default=SCENE, help="the scene variant (melt-dwell-climb-ice-friction: ice on ice's "
                    "friction, a pre-loaded brace); the cost is then measured only with --cost")
    ap.add_argument("--ice", default=None, metavar="NAME,...", help=f"ices of the grid, by name ({', '.join(ICE)}); "
                    "default all")
    ap.add_argument("--cost", action="store_true", help="only the thermal side's cost (writes --cost-json)")
    ap.add_argument("--repeats", type=int, default=5, help="alternating on/off runs for the cost")
    ap.add_argument("--cost-json", type=Path, default=RESULTS / "melt_cost.json")
    ap.add_argument("--json", type=Path, default=RESULTS / "melt_dwell.json")
    ap.add_argument("--png", type=Path, default=RESULTS / "melt_dwell.png")
    a = ap.parse_args(argv)
    if a.ice is not None and not set(a.ice.split(",")) <= set(ICE):
        ap.error(f"--ice {a.ice!r}: valid names are {', '.join(ICE)}")
    ices = {k: v for k, v in ICE.items() if a.ice is None or k in a.ice.split(",")}
    cost = (thermal_cost(repeats=a.repeats) if a.cost or (a.set_points is None and a.scene == SCENE)
            else None)
    if cost is not None:
        print_cost(cost)
    if a.cost:
        a.cost_json.parent.mkdir(parents=True, exist_ok=True)
        a.cost_json.write_text(json.dumps(cost, indent=2) + "\n")
        print(f"wrote {a.cost_json}")
        return 0
    out = {"scene": a.scene, "thermal_cost": cost}
    set_points, tol = ((10.0, 40.0), 4.0) if a.quick else ((10.0, 20.0, 30.0, 40.0), 1.0)
    if a.set_points is not None:
        set_points = tuple(float(c) for c in a.set_points.split(","))
    if a.tolerance is not None:
        tol = a.tolerance
    table, t0 = [], time.perf_counter()
    print(f"{'ice':>18} {'set-point':>10} {'critical dwell':>16} {'runs':>5} {'wall':>7}  failures named")
    for ice, sets in ices.items():
        for sp in set_points:
            w0 = time.perf_counter()
            r = critical_dwell(sp, sets, tol, a.scene)
            row = {"ice": ice, "set_point_C": sp, **r, "wall_s": time.perf_counter() - w0}
            table.append(row)
            cd = (f"{r['critical_dwell_s']:.1f} ± {0.5 * (r['bracket_s'][1] - r['bracket_s'][0]):.1f} s"
                  if r["critical_dwell_s"] is not None else r["note"])
            other = sorted({x["failure_kind"] for x in r["runs"] if x["outcome"] != "success"} - {"mobility"})
            named = sorted({x["failure"] for x in r["runs"] if x.get("failure")})
            print(f"{ice:>18} {sp:>8.0f} C {cd:>16} {len(r['runs']):>5} {row['wall_s']:>6.0f}s"
                  + (f"  {', '.join(named)}" if named else "")
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
