"""Speed versus accuracy of the default scene (crescent screw traverse) and the parallel-walls scene.

    .venv/bin/python bench/tradeoff.py [--quick] [--json FILE] [--plot PNG] [--match TEXT] [--no-held]
                                       [--repeats N] [--anchor implicitfast:0.01] [--events [FILE]]

For each setting — every integrator at several steps / tolerances, both contact back ends
(screw_sdf_contact / hull_contact: the `type` of component `contact` swapped in the resolved
configuration), 1/2/4/8 contact samples per screw ring (SDF back end), and the multibody
optimisation on/off (its knob is `screw_pairs`: `embedded` = a screw pair is one DOF with the
rear screw's inertia folded in, the optimised model; `mimic_crba` = the pair kept as a mimic
constraint solved through the CRBA, the unoptimised path) — it runs the scene and reports:

  wall s, RTF     wall time of the run (the fastest of --repeats identical runs) and simulated / wall time
  x MuJoCo        RTF / MuJoCo's RTF, per interleaved pair (each snakesim run followed by a MuJoCo run,
                  bench/interleaved.py): median [min] by the wall clock and by CPU time. The anchor
                  (--anchor INTEGRATOR:DT) is MuJoCo's 10-module screw snake at implicitfast, 10 ms: its
                  large stable step, issue 24's speed anchor (euler:0.001, the former anchor, for comparison)
  pos err m       max over time of |tail (x, y) − reference| (traverse) or |CoM − reference| (walls)
  yaw err rad     max over time of |tail yaw − reference| (traverse; the fig. 14 quantities)
  stable          no non-finite-state or integrator-failure stop (the framework's stop;
                  never a silent NaN). A run the scene itself stops (the walls' mobility
                  monitor) is compared up to the earlier of its end and the reference's.

The reference is the same scene at rk4, dt = 0.25 ms (tests/validation/validation_scenes.py),
computed in the same run. MuJoCo's 10-module screw snake (../shared/peers/mujoco_snake.py, implicitfast at
10 ms by default) is timed in the same process after each of a setting's runs. Then the held-robot
cases (bench/held_cases.py: a held pair on a slope, the default scene's stop phase, the walls
hold) with each setting's creep error against a converged reference (--no-held skips them). `--quick`: traverse 2 s (compressed schedule), walls 1.5 s and a
reduced set of settings (a few minutes); full: 45 s traverse, 4 s walls, every setting.

Events (--events [FILE], default bench/results/events.json): the event cases of bench/events.py (drops, a
braced robot started off a wall, a stiff bounce, a free robot, the Mini EELS crawl, a /sim/set_pose drop) at
each of its integrator settings, read from its JSON (run first, --quick as here, when the file is missing):
a table per setting (cases completed, the worst error over the cases, CPU time and RTF by CPU time over all of
them) and two more Pareto panels: each setting's RTF against its worst error (a setting that failed a case on
the top edge), and every case's point. `--scene none --no-held --events` plots the events alone.

The picture (--plot; docs/images/tradeoff-pareto.png) is drawn by bench/tradeoff_plot.py: the scene's own
setting (the default integrator and step) a starred point named "default", every label placed clear of the
others, of the markers and of the legend.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):   # as `snakesim` runs (blas_threads.py)
    os.environ.setdefault(_var, "1")

import json  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import click  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "validation"))
from validation_scenes import REFERENCE, run, session, track_error  # noqa: E402

from snakesim.framework.integrators.rosenbrock_w import RosenbrockWParams  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import held_cases  # noqa: E402
from interleaved import available, compare  # noqa: E402
from tradeoff_plot import DEFAULT, plot  # noqa: E402


def _track(result, scene):
    """(t, [x, y, yaw]) for the traverse; (t, [CoM x, y, z]) for the walls (no yaw)."""
    t = np.asarray(result["t"], dtype=float)
    if "tail_pose.pose" in [f"{r.comp}.{r.port}" for r in result.log.refs]:
        p = np.array(result["tail_pose.pose"], dtype=float)
        p[:, 2] = np.unwrap(p[:, 2])
        return t, p, True
    return t, np.array(result["robot.com"], dtype=float), False


def _errors(t, p, has_yaw, t_ref, p_ref):
    if has_yaw:
        return track_error(t, p, t_ref, p_ref)
    end = min(t[-1], t_ref[-1])
    keep = t_ref <= end + 1e-9
    d = np.column_stack([np.interp(t_ref[keep], t, p[:, j]) for j in range(3)]) - p_ref[keep]
    return {"pos_err_m": float(np.linalg.norm(d, axis=1).max()), "yaw_err_rad": None}


def _patch(contact_type=None, per_ring=None, screw_pairs=None):
    def apply(resolved):
        c = resolved.components
        if contact_type is not None:
            c["contact"].type = contact_type
            if contact_type == "hull_contact":
                for k in ("rings", "per_ring", "phase", "v_eps", "regularisation", "ev_floor", "broad_phase", "margin"):
                    c["contact"].params.pop(k, None)
                # ports only the SDF back end has are not recorded
                resolved.record[:] = [(r, w) for r, w in resolved.record if r != "contact.screw_normal_force"]
        if per_ring is not None:
            c["contact"].params["per_ring"] = per_ring
        if screw_pairs is not None:
            c["robot"].params["screw_pairs"] = screw_pairs
    return apply


def settings(quick: bool):
    out = []
    def I(name, dt, **p):  # noqa: E743
        shown = p
        if name == "rosenbrock_w":
            # every parameter explicit (the scene's own rosenbrock_w params would merge under a partial override);
            # fixed steps unless the setting says error control (the integrator's default since issue 24)
            p.setdefault("step_control", "fixed")
            p.setdefault("jacobian_every", 1)
            p = {**RosenbrockWParams().model_dump(mode="json"), **shown}
        return {"label": f"{name} dt={dt:g}" + "".join(
            f" {k}={v:g}" if isinstance(v, (int, float)) else f" {k}={v}" for k, v in shown.items()),
            "integrator": {"name": name, "params": p}, "dt": dt}
    # the scene's own setting, as a user runs it (the default scene: rosenbrock_w under error control at 20 ms)
    out.append({"label": DEFAULT, "integrator": None, "dt": None})
    steps = {"rk4": [5e-4, 1e-3, 2e-3] if quick else [5e-4, 1e-3, 2e-3, 4e-3],
             "semi_implicit_euler": [2.5e-4, 5e-4, 1e-3] if quick else [1e-4, 2.5e-4, 5e-4, 1e-3, 2e-3],
             "rosenbrock2": [2e-3] if quick else [1e-3, 2e-3, 5e-3]}
    for name, dts in steps.items():
        for dt in dts:
            out.append(I(name, dt, **({"jacobian_every": 10} if name == "rosenbrock2" else {})))
    # the linearly implicit step on the components' analytic Jacobians (framework/linearization.py)
    for dt in ([5e-3, 1e-2] if quick else [2.5e-3, 5e-3, 1e-2]):
        out.append(I("rosenbrock_w", dt, method="ros2"))
    for every in (2, 3, 4, 5):      # the Jacobian (and its O(links) factorisation) reused for a few steps
        out.append(I("rosenbrock_w", 5e-3, method="ros2", jacobian_every=every))
    out.append(I("rosenbrock_w", 2.5e-3, method="ros2", jacobian_every=3))     # the default scene's setting
    for every in (1, 2):            # 1/150 s: the largest step under 10 ms that divides the 50 Hz record
        out.append(I("rosenbrock_w", 1.0 / 150.0, method="ros2", jacobian_every=every))
    # J refreshed at the schedule's set-point jumps and for 50 ms after (jacobian_refresh: on_sources), else
    # every 8 steps: a stale J costs accuracy only where the friction's slip regime changes
    for dt in (5e-3, 1.0 / 150.0):
        out.append(I("rosenbrock_w", dt, method="ros2", jacobian_every=8, jacobian_refresh="on_sources",
                     refresh_window=0.05))
    # ... and the transient after each jump at a quarter of the step (refresh_substeps: 4) for 100 ms
    for dt in (5e-3, 1.0 / 150.0, 1e-2):
        out.append(I("rosenbrock_w", dt, method="ros2", jacobian_every=8, jacobian_refresh="on_sources",
                     refresh_window=0.1, refresh_substeps=4))
    # error control (issue 24): steps of the base step / 2^k chosen by ros2's embedded estimate; the integrator's
    # default tolerances (3e-4 m, 3e-3 m/s, 3e-3), 3x tighter, and the default scene's (10x looser, 20 ms, J every 8
    # steps and at the schedule's jumps)
    out.append(I("rosenbrock_w", 1e-2, method="ros2", step_control="error"))
    out.append(I("rosenbrock_w", 1e-2, method="ros2", step_control="error", atol_q=1e-4, atol_v=1e-3, rtol=1e-3))
    out.append(I("rosenbrock_w", 2e-2, method="ros2", step_control="error", atol_q=3e-3, atol_v=3e-2, rtol=3e-2,
                 jacobian_every=8, jacobian_refresh="on_sources", refresh_window=0.1))
    for dt in ([1e-2] if quick else [5e-3, 1e-2]):
        out.append(I("rosenbrock_w", dt, method="ros34pw2"))
    if not quick:
        out.append(I("rosenbrock_w", 1e-2, method="ros34pw2", jacobian_every=2))
    for rtol in ([1e-4, 1e-6] if quick else [1e-3, 1e-4, 1e-6, 1e-8]):
        out.append(I("dopri5", 1e-3, rtol=rtol, atol=rtol * 1e-2))
    base = {"integrator": {"name": "rk4", "params": {}}, "dt": 1e-3}
    out.append({**base, "label": "rk4 dt=0.001 hull_contact", "patch": {"contact_type": "hull_contact"}})
    for n in [1, 2, 4, 8]:
        out.append({**base, "label": f"rk4 dt=0.001 per_ring={n}", "patch": {"per_ring": n}})
    for sp in ["embedded", "mimic_crba"]:
        out.append({**base, "label": f"rk4 dt=0.001 screw_pairs={sp}", "patch": {"screw_pairs": sp}})
    return out


SCENES = {  # scene -> (--set items, quick horizon, full horizon)
    "surface-screw-traverse": (["settle=0.5", "phase=1.5"], 2.0, None),
    "parallel-walls-climb": ([], 1.5, 4.0),
}


ANCHOR = ("implicitfast", 0.01)     # MuJoCo's snake at its large stable step (issue 24's speed anchor)


def parse_anchor(text: str) -> tuple[str, float]:
    """'implicitfast:0.01' -> ('implicitfast', 0.01); the integrator name as MuJoCo spells it."""
    names = {n.lower(): n for n in ("Euler", "RK4", "implicit", "implicitfast")}
    name, _, dt = text.partition(":")
    if name.lower() not in names or not dt:
        raise click.BadParameter(f"'{text}': INTEGRATOR:DT with INTEGRATOR one of {', '.join(names.values())}")
    return names[name.lower()], float(dt)


def measure(scene, sets, horizon, s, repeats=1, anchor=ANCHOR):
    """One setting: its session built once and run ``repeats`` times (deterministic: the same result), each
    run followed by a run of MuJoCo's 10-module snake (bench/interleaved.py), both timed by the wall clock
    and by CPU time. Speed: the fastest run (RTF) and, per interleaved pair, the ratio to MuJoCo."""
    sim = {"duration": horizon, "dt": s["dt"], "integrator": s["integrator"]}
    try:
        sess = session(scene, sets, sim, _patch(**s.get("patch", {})))
    except Exception as e:                      # a setting the build rejects (e.g. a record rate)
        return {"error": f"{type(e).__name__}: {e}"}
    last = []

    def one():
        r = sess.run()
        last[:] = [r]
        return r.summary

    cmp = compare(one, modules=10, mujoco_dt=anchor[1], mujoco_duration=5.0, repeats=repeats,
                  mujoco_integrator=anchor[0])
    r = last[0]
    sm = r.summary
    best = min(cmp["repeats"], key=lambda x: x["snakesim_wall_s"])
    return {"result": r, "wall_s": best["snakesim_wall_s"], "rtf": cmp["snakesim_rtf_wall_best"],
            "rtf_cpu": cmp["snakesim_rtf_cpu_best"], "sim_s": sm["sim_time_s"],
            "x_mujoco_wall": cmp.get("ratio_wall"), "x_mujoco_cpu": cmp.get("ratio_cpu"),
            "mujoco_rtf_wall": [x.get("mujoco_rtf_wall") for x in cmp["repeats"]],
            "stable": r.last_good_state is None, "stop": sm["stop_reason"]}


@click.command()
@click.option("--quick", is_flag=True, help="Shorter horizons, fewer settings (a few minutes).")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default="bench/results/tradeoff.json",
              show_default=True, help="Write the figures here (machine-readable).")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False), default="bench/results/tradeoff.png",
              show_default=True, help="Pareto plot (PNG).")
@click.option("--scene", "only", multiple=True, help="Only these scenes.")
@click.option("--held/--no-held", default=True, show_default=True,
              help="Also the held-robot cases (bench/held_cases.py: slope, stop phase, walls) with creep errors.")
@click.option("--match", multiple=True, help="Only the settings whose label contains one of these texts "
                                             "(e.g. --match rosenbrock_w); the held cases are not filtered.")
@click.option("--repeats", default=3, show_default=True,
              help="Runs per setting, each followed by a MuJoCo run (interleaved pairs); the fastest RTF is kept.")
@click.option("--anchor", "anchor_text", default="implicitfast:0.01", show_default=True,
              help="MuJoCo's snake as INTEGRATOR:DT (implicitfast:0.01, euler:0.001, ...).")
@click.option("--events", "events_path", is_flag=False, flag_value=str(Path(__file__).resolve().parent / "results"
                                                                       / "events.json"), default=None,
              help="Add bench/events.py's event cases (its JSON; run first when missing) to the tables and the "
                   "Pareto plot. Without FILE: bench/results/events.json.")
def main(quick, json_path, plot_path, only, held, match, repeats, anchor_text, events_path):
    anchor = parse_anchor(anchor_text)
    rows = []
    if available():
        print("Speed: each setting's session is run --repeats times, each run followed by MuJoCo's 10-module screw "
              f"snake\n({anchor[0]}, {anchor[1] * 1e3:g} ms, 5 s; ../shared/peers/mujoco_snake.py) in this process "
              "(bench/interleaved.py). "
              "'x MuJoCo' = RTF / MuJoCo's RTF per pair:\nwall clock median [min], and by CPU time "
              "(process_time: what other processes take of the core does not count) median [min].")
    else:
        print("MuJoCo not available (pip install mujoco): no speed ratio")

    def ratio(row, clock):
        r = row.get(f"x_mujoco_{clock}")
        return f"{r['median']:.2f} [{r['min']:.2f}]" if r else "—"
    for scene, (sets, qh, fh) in SCENES.items():
        if only and scene not in only:
            continue
        if quick:
            horizon = qh
        else:
            horizon = fh or 45.0
            sets = [] if scene == "surface-screw-traverse" else sets
        ref_s, ref = run(scene, sets, {"duration": horizon, "dt": REFERENCE["dt"], "integrator": REFERENCE["integrator"]})
        t_ref, p_ref, _ = _track(ref, scene)
        print(f"\n{scene}: {horizon:g} s; reference rk4 dt={REFERENCE['dt']:g}: {ref.summary['stop_reason']}, "
              f"RTF {ref.summary['real_time_factor']:.3g}", flush=True)
        chosen = [st for st in settings(quick) if not match or any(m in st["label"] for m in match)]
        for name in dict.fromkeys(st["integrator"]["name"] for st in chosen if st["integrator"]):   # kernels
            run(scene, sets, {"duration": 0.05, "dt": 5e-3, "integrator": {"name": name, "params": {}}})
        print("| setting | wall s | RTF | x MuJoCo wall | x MuJoCo CPU | pos err m | yaw err rad | stable | stop |\n"
              "|---|---:|---:|---:|---:|---:|---:|---|---|")
        for s in chosen:
            m = measure(scene, sets, horizon, s, repeats, anchor)
            row = {"scene": scene, "setting": s["label"], "horizon_s": horizon}
            if "error" in m:
                row.update(error=m["error"], stable=False)
                print(f"| {s['label']} | — | — | — | — | — | — | build error | {m['error'][:60]} |")
            else:
                t, p, yaw = _track(m.pop("result"), scene)
                row.update(m, **_errors(t, p, yaw, t_ref, p_ref))
                ye = "—" if row["yaw_err_rad"] is None else f"{row['yaw_err_rad']:.2e}"
                print(f"| {s['label']} | {row['wall_s']:.2f} | {row['rtf']:.3g} | {ratio(row, 'wall')} | "
                      f"{ratio(row, 'cpu')} | {row['pos_err_m']:.2e} | {ye} | "
                      f"{'yes' if row['stable'] else 'NO'} | {row['stop'][:60]} |", flush=True)
            rows.append(row)
    held_rows = held_cases.main(quick) if held else []
    event_rows = events_table(load_events(Path(events_path), quick)) if events_path else []
    if json_path:
        Path(json_path).parent.mkdir(parents=True, exist_ok=True)
        Path(json_path).write_text(json.dumps({"quick": quick, "reference": REFERENCE, "repeats": repeats,
                                               "anchor": {"integrator": anchor[0], "dt": anchor[1]},
                                               "rows": rows, "held": held_rows, "events": event_rows},
                                              indent=1, default=str) + "\n")
        print(f"\nwrote {json_path}")
    if plot_path:
        plot(rows, Path(plot_path), event_rows)
        print(f"\nwrote {plot_path}")


def load_events(path: Path, quick: bool) -> dict:
    """bench/events.py's results: read from ``path``, or run (at --quick as this run) and written there."""
    if path.exists():
        print(f"\nevent cases: {path} (bench/events.py)")
        return json.loads(path.read_text())
    import events
    print(f"\nevent cases: {path} missing, running bench/events.py{' --quick' if quick else ''}", flush=True)
    res = events.collect(quick)
    events.write(res, str(path), str(path.with_suffix(".png")))
    return res


def events_table(res: dict) -> list[dict]:
    """Per event setting, over every case it ran: cases completed, the worst error (m: bench/events.py's accuracy
    figure: rest pose, bounce apex, tail), CPU s and simulated s in all, RTF by CPU time; and each case's point."""
    out = []
    for setting in res["settings"]:
        rs = [r for r in res["rows"] if r.get("setting") == setting and "error" not in r]
        if not rs:
            continue
        failed = [r["case"] for r in rs if not r["completed"]]
        errs = [r["error_m"] for r in rs if r.get("error_m") is not None]
        cpu, sim = sum(r["cpu_s"] for r in rs), sum(r["sim_s"] for r in rs)
        out.append({"setting": setting, "cases": len(rs), "failed": failed,
                    "worst_error_m": max(errs) if errs else None, "cpu_s": cpu, "sim_s": sim,
                    "rtf_cpu": sim / max(cpu, 1e-9),
                    "points": [{"case": r["case"], "rtf_cpu": r["rtf_cpu"], "error_m": r.get("error_m"),
                                "completed": r["completed"]} for r in rs]})
    print("\nevents (bench/events.py; error: rest pose, bounce apex or crawl tail against each case's converged "
          "reference)\n| setting | cases | failed | worst error m | CPU s | RTF CPU |\n|---|---:|---|---:|---:|---:|")
    for e in out:
        we = "—" if e["worst_error_m"] is None else f"{e['worst_error_m']:.2e}"
        print(f"| {e['setting']} | {e['cases']} | {', '.join(e['failed']) or '—'} | {we} | {e['cpu_s']:.2f} | "
              f"{e['rtf_cpu']:.3g} |")
    return out


if __name__ == "__main__":
    main()
