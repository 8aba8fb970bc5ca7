"""Events inside a step (issue 24): contact onset, impacts and free flight at each integrator setting.

    .venv/bin/python bench/events.py [--quick] [--case NAME ...] [--setting TEXT ...] [--json FILE] [--plot PNG]
                                     [--refresh-references]

Cases (the real scenes and components; helpers in tests/validation/event_scenes.py, shared with the tests):

  drop-1cm, drop-5cm, drop-20cm   the default scene's robot released 1, 5, 20 cm above its resting height onto
                                  flat ice, screws idle (event_scenes.drop)
  tube-off-wall, u-channel-off-wall
                                  the body-respecting braces (tube-body-brace, u-channel-body-brace-traverse)
                                  translated along the wall normal until the screws bracing one wall are
                                  0.5 mm clear of it, then held (event_scenes.off_wall)
  bounce-stiff                    the 5 cm drop onto a stiff, lightly damped ice (screw contact k = 1e6 N/m,
                                  c = 20 N·s/m per contact): the first bounce's apex against the reference
  free-robot                      robot-zero-g with every joint moving (v0 bend 0.6, twist −0.4, screw 5 rad/s;
                                  q0 bend 0.1, twist −0.2; base twist [0.1, 0, 0, 0.2, −0.1, 0.3]): drift per
                                  second of the kinetic energy, P and L_G (the multibody's outputs: Pinocchio's
                                  centroidal momentum and kinetic energy of the state)
  mini-eels-crawl                 the Mini EELS crawl (body contact, serpenoid gait) against a converged RK4;
                                  its own scene setting is RK4 at 0.5 ms (the 'scene' row)
  set-pose-drop                   the default robot resting on the ice, placed 1.5 cm up, at rest, by a
                                  /sim/set_pose request at t = 0.5 s (the ROS 2 gate ros2_sim_control with its
                                  DDS poll replaced by one scripted message: event_scenes.set_pose_drop)

Settings: ``scene`` (each case's own scene setting: what a user gets), rosenbrock_w under error control at a 10 ms
base step with its default tolerances (atol_q 3e-4 m, atol_v 3e-3 m/s, rtol 3e-3), 3x tighter and 10x looser,
``step_control: fixed`` at 10 ms as the default scene had it before error control (ros2, J every 8 steps and at
the schedule's jumps, 100 ms window at 4 substeps), RK4 at 1 ms, and rosenbrock_w fixed at 2.5 ms (ros2, J every 3
steps: the default scene's setting before that). Every rosenbrock_w setting names all its parameters (a scene's
own would merge under a partial override).

Columns: completed (else the outcome's failure kind and stop reason), rise (m: the centre of mass's highest point
above where it started, or above where set_pose released it: > 0 means energy from nowhere), rest (m: the largest
distance between a link origin at the end and in the reference), apex (bounce: the first bounce's apex above the
release height, interpolated through the samples around it, and its error), tail (crawl: the tail's largest xy
distance from the reference over the run), drift (free robot: energy, P, L_G in %/s), CPU s (the step loop's
time.process_time, the summary's cpu_time_s), RTF (sim s / wall s) and RTF CPU (sim s / CPU s), x MuJoCo CPU (RTF
CPU over the anchor's, below), steps/rejected/h_min of error control. The accuracy figure of a case (JSON
``error_m``, the figure's y axis, bench/tradeoff.py --events) is the bounce's apex error, the crawl's tail error,
else the end pose; a run that failed has none. The bounce's end pose is mid-bounce (not a rest pose).

References, computed in the same run and cached in bench/results/events-reference-<case>-<duration>s.npz (the
settings in the file; --refresh-references recomputes): RK4 at 0.2 ms for the drops and the set_pose drop
(0.1 ms moves the rest pose by < 0.05 mm), RK4 at 0.05 ms for the stiff bounce (0.025 ms moves its apex by
0.02 mm), RK4 at 0.25 ms for the crawl and 1 ms for the free robot (its invariants drift < 1e-10 /s), and for the
braced robot rosenbrock_w under error control at atol_q 1e-5 (event_scenes.WALL_REFERENCE: RK4 needs ~20 µs steps
for the walls' regularised friction). ``--check-references`` also runs each reference at half its step or a 10x
tighter tolerance and prints how far its end pose moves.

The speed anchor (issue 24): MuJoCo's 10-module screw snake at implicitfast, 10 ms (../shared/peers/
mujoco_snake.py, bench/interleaved.py), timed in this process before and after the cases.

Writes bench/results/events.json (--json) and a figure of CPU time against the accuracy measure per case
(bench/results/events.png, --plot).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):   # as `snakesim` runs (blas_threads.py)
    os.environ.setdefault(_var, "1")

import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import click  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "validation"))
import event_scenes as ev  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from interleaved import MujocoSnake, available  # noqa: E402

from snakesim.framework.integrators.rosenbrock_w import RosenbrockWParams  # noqa: E402
from snakesim.framework.session import load_session  # noqa: E402

RESULTS = ROOT / "bench" / "results"
G = 9.81


# -- integrator settings ------------------------------------------------------------------------------------------

def _w(**params) -> dict:
    """rosenbrock_w with every parameter given (a scene's own rosenbrock_w params would merge under a partial one)."""
    return {"name": "rosenbrock_w", "params": {**RosenbrockWParams().model_dump(mode="json"), **params}}


RK4 = {"name": "rk4", "params": {}}
#: label -> (integrator or None: the case's scene's own, dt or None)
SETTINGS = {
    "scene": (None, None),
    "rosenbrock_w error 10ms default tol": (_w(), 0.01),
    "rosenbrock_w error 10ms tight (1e-4, 1e-3, 1e-3)": (_w(atol_q=1e-4, atol_v=1e-3, rtol=1e-3), 0.01),
    "rosenbrock_w error 10ms loose (3e-3, 3e-2, 3e-2)": (_w(atol_q=3e-3, atol_v=3e-2, rtol=3e-2), 0.01),
    "rosenbrock_w fixed 10ms (J/8, on_sources 0.1 s x4)": (_w(step_control="fixed", jacobian_every=8,
                                                              jacobian_refresh="on_sources", refresh_window=0.1,
                                                              refresh_substeps=4), 0.01),
    "rk4 1ms": (RK4, 1e-3),
    "rosenbrock_w fixed 2.5ms (J/3)": (_w(step_control="fixed", jacobian_every=3), 0.0025),
}


# -- cases ---------------------------------------------------------------------------------------------------------

BOUNCE_SETS = ["components.contact.params.material.k=1.0e6", "components.contact.params.material.c=20.0"]
SET_POSE_AT, SET_POSE_HEIGHT = 0.5, 0.015


def _drop(h):
    return lambda integ, dt, dur: ev.drop(h, integ, dt, dur)


def _wall(scene):
    return lambda integ, dt, dur: ev.off_wall(scene, integ, dt, dur)


def _crawl(integ, dt, dur):
    sim = {"duration": dur}
    if integ is not None:
        sim.update(integrator=integ, dt=dt)
    return load_session("mini-eels-crawl", overrides=["record=[robot.com, tail_pose.pose, robot.link_poses]"],
                        sim_overrides=sim).run()


#: name -> kind, run(integrator, dt, duration), (quick, full) duration s, reference (integrator, dt), its check
CASES = {
    "drop-1cm": dict(kind="drop", run=_drop(0.01), durations=(1.0, 2.0), ref=(RK4, 2e-4), check=(RK4, 1e-4)),
    "drop-5cm": dict(kind="drop", run=_drop(0.05), durations=(1.0, 2.0), ref=(RK4, 2e-4), check=(RK4, 1e-4)),
    "drop-20cm": dict(kind="drop", run=_drop(0.20), durations=(1.0, 2.0), ref=(RK4, 2e-4), check=(RK4, 1e-4)),
    "tube-off-wall": dict(kind="wall", scene=ev.WALL_SCENES["tube"], run=_wall(ev.WALL_SCENES["tube"]),
                          durations=(1.5, 3.0),
                          ref=(ev.WALL_REFERENCE, ev.WALL_REFERENCE_DT),
                          check=(_w(atol_q=1e-6, atol_v=1e-5, rtol=1e-5, h_min=1e-10), 0.01)),
    "u-channel-off-wall": dict(kind="wall", scene=ev.WALL_SCENES["u-channel"], run=_wall(ev.WALL_SCENES["u-channel"]),
                               durations=(1.5, 2.9),
                               ref=(ev.WALL_REFERENCE, ev.WALL_REFERENCE_DT),
                               check=(_w(atol_q=1e-6, atol_v=1e-5, rtol=1e-5, h_min=1e-10), 0.01)),
    "bounce-stiff": dict(kind="bounce", run=lambda integ, dt, dur: ev.drop(0.05, integ, dt, dur, sets=BOUNCE_SETS),
                         durations=(0.6, 1.0), ref=(RK4, 5e-5), check=(RK4, 2.5e-5)),
    "free-robot": dict(kind="free", run=ev.free_robot, durations=(1.0, 2.0), ref=(RK4, 1e-3), check=(RK4, 5e-4)),
    "mini-eels-crawl": dict(kind="crawl", run=_crawl, durations=(2.0, 20.0), ref=(RK4, 2.5e-4), check=(RK4, 1.25e-4)),
    "set-pose-drop": dict(kind="set_pose",
                          run=lambda integ, dt, dur: ev.set_pose_drop(SET_POSE_HEIGHT, integ, dt, dur, SET_POSE_AT),
                          durations=(1.5, 2.0), ref=(RK4, 2e-4), check=(RK4, 1e-4)),
}
KEYS = ("t", "robot.com", "robot.link_poses", "tail_pose.pose", "robot.momentum", "robot.energy")


class Recorded:
    """What the metrics read of a run (arrays by key, the summary); made from a run or a cached reference."""

    def __init__(self, arrays: dict, summary: dict):
        self.arrays, self.summary = arrays, summary

    @classmethod
    def of(cls, r) -> "Recorded":
        have = {f"{x.comp}.{x.port}" for x in r.log.refs} | {"t"}
        arrays = {k: np.asarray(r[k], dtype=float) for k in KEYS if k in have}
        keep = ("completed", "outcome", "failure_kind", "stop_reason", "sim_time_s", "wall_time_s", "cpu_time_s",
                "real_time_factor", "integrator")
        return cls(arrays, {k: r.summary.get(k) for k in keep})

    def __getitem__(self, key):
        return self.arrays[key]

    def __contains__(self, key):
        return key in self.arrays


def reference(name: str, case: dict, duration: float, refresh: bool = False, spec=None) -> Recorded:
    """The case's reference run (cached in bench/results, keyed by case, duration and setting)."""
    integ, dt = spec or case["ref"]
    meta = json.dumps({"case": name, "duration": duration, "integrator": integ, "dt": dt}, sort_keys=True)
    path = RESULTS / f"events-reference-{name}-{duration:g}s.npz"
    if spec is None and path.exists() and not refresh:
        z = np.load(path, allow_pickle=False)
        if str(z["meta"]) == meta:
            return Recorded({k: z[k] for k in z.files if k not in ("meta", "summary")}, json.loads(str(z["summary"])))
    rec = Recorded.of(case["run"](integ, dt, duration))
    if not rec.summary["completed"]:
        raise RuntimeError(f"the reference of {name} did not complete: {rec.summary['stop_reason']}")
    if spec is None:
        RESULTS.mkdir(parents=True, exist_ok=True)
        np.savez(path, meta=meta, summary=json.dumps(rec.summary, default=str), **rec.arrays)
    return rec


# -- metrics -------------------------------------------------------------------------------------------------------

def rise(rec: Recorded, kind: str) -> float | None:
    """m: the centre of mass's highest point above its start (set_pose: above where it was released)."""
    if kind == "free":
        return None
    z = rec["robot.com"][:, 2]
    if kind == "set_pose":
        after = rec["t"] > SET_POSE_AT + 1e-9
        if not after.any():
            return None
        z = z[after]
    return float(z.max() - z[0])


def end_offset(rec: Recorded, ref: Recorded) -> float | None:
    """m: the largest distance between a link origin at the end of the run and of the reference (None when the
    run stopped early: its end is not the reference's)."""
    if not rec.summary["completed"]:
        return None
    a = rec["robot.link_poses"][-1].reshape(-1, 7)[:, :3]
    b = ref["robot.link_poses"][-1].reshape(-1, 7)[:, :3]
    return float(np.linalg.norm(a - b, axis=1).max())


def bounce_apex(rec: Recorded, height: float = 0.05) -> float | None:
    """m above the release height: the highest point of the centre of mass after its first landing (the lowest
    point within the free fall's time + 0.1 s), refined by the parabola through the samples around it (exact
    for a ballistic centre of mass)."""
    t, z = rec["t"], rec["robot.com"][:, 2]
    first = t <= math.sqrt(2 * height / G) + 0.1
    land = int(np.argmin(np.where(first, z, np.inf)))
    if land >= len(z) - 2:
        return None
    k = land + 1 + int(np.argmax(z[land + 1:]))
    apex = z[k]
    if 0 < k < len(z) - 1:
        a, b, c = z[k - 1], z[k], z[k + 1]
        den = a - 2 * b + c
        if den < 0:
            apex = b - 0.125 * (c - a) ** 2 / den
    return float(apex - z[0])


def tail_error(rec: Recorded, ref: Recorded) -> float | None:
    """m: the tail's largest xy distance from the reference over the run (up to the earlier end)."""
    if "tail_pose.pose" not in rec:
        return None
    t, p, tr, pr = rec["t"], rec["tail_pose.pose"], ref["t"], ref["tail_pose.pose"]
    keep = tr <= t[-1] + 1e-9
    d = np.column_stack([np.interp(tr[keep], t, p[:, j]) for j in range(2)]) - pr[keep, :2]
    return float(np.hypot(d[:, 0], d[:, 1]).max())


def measure(name: str, case: dict, rec: Recorded, ref: Recorded) -> dict:
    sm = rec.summary
    integ = sm["integrator"] or {}
    row = {"case": name, "completed": bool(sm["completed"]), "outcome": sm.get("outcome"),
           "failure_kind": sm.get("failure_kind"), "stop": sm["stop_reason"], "sim_s": sm["sim_time_s"],
           "cpu_s": sm["cpu_time_s"], "wall_s": sm["wall_time_s"], "rtf": sm["real_time_factor"],
           "rtf_cpu": sm["sim_time_s"] / max(sm["cpu_time_s"], 1e-9), "steps": integ.get("steps"),
           "rejected": integ.get("rejected"), "h_smallest": integ.get("h_smallest"),
           "rise_m": rise(rec, case["kind"]), "rest_m": end_offset(rec, ref)}
    if case["kind"] == "bounce":
        row["apex_m"], row["apex_ref_m"] = bounce_apex(rec), bounce_apex(ref)
        row["apex_err_m"] = (abs(row["apex_m"] - row["apex_ref_m"])
                             if row["apex_m"] is not None and row["apex_ref_m"] is not None else None)
    if case["kind"] == "crawl":
        row["tail_err_m"] = tail_error(rec, ref)
    if case["kind"] == "free":
        row["drift_per_s"] = ev.invariant_drift(rec)
    row["error_m"] = accuracy(row)
    return row


def accuracy(row: dict) -> float | None:
    """The case's one accuracy figure for the plots and the Pareto (m): the bounce apex error, the crawl's tail
    error, else the end pose against the reference; None for a run that failed."""
    if not row["completed"]:
        return None
    for key in ("apex_err_m", "tail_err_m", "rest_m"):
        if row.get(key) is not None:
            return row[key]
    return None


# -- running -------------------------------------------------------------------------------------------------------

def mujoco_anchor(duration: float = 5.0) -> dict | None:
    """MuJoCo's 10-module screw snake at implicitfast 10 ms: RTF by wall clock and CPU time (best of 3)."""
    if not available():
        return None
    mj = MujocoSnake(10, 0.01, "implicitfast")
    mj.time(0.5)
    best = {"wall": 0.0, "cpu": 0.0}
    for _ in range(3):
        w, c, n = mj.time(duration)
        best["wall"] = max(best["wall"], n * mj.dt / w)
        best["cpu"] = max(best["cpu"], n * mj.dt / max(c, 1e-9))
    return {"integrator": "implicitfast", "dt": 0.01, "modules": 10, "rtf_wall": best["wall"], "rtf_cpu": best["cpu"]}


def _fmt(v, scale=1e3, digits=3):
    return "—" if v is None else f"{v * scale:.{digits}g}"


def row_line(setting: str, row: dict) -> str:
    """One table row (``x MuJoCo``: RTF by CPU time over the anchor's, when it was measured)."""
    ok = "yes" if row["completed"] else f"NO ({row['failure_kind'] or row['outcome']})"
    extra = ""
    if "apex_m" in row:
        extra = f"apex {_fmt(row['apex_m'])} mm (err {_fmt(row['apex_err_m'])})"
    elif "tail_err_m" in row:
        extra = f"tail err {_fmt(row['tail_err_m'])} mm"
    elif "drift_per_s" in row:
        d = row["drift_per_s"]
        extra = "drift %/s E {:.2g}, P {:.2g}, L_G {:.2g}".format(*(100 * d[k] for k in ("energy", "P", "L_G")))
    hs = row.get("h_smallest")
    steps = "—" if row["steps"] is None else (f"{row['steps']}" + (f" / {row['rejected']} / {hs:.2g}"
                                                                   if row.get("rejected") is not None else ""))
    return (f"| {setting} | {ok} | {_fmt(row['rise_m'])} | {_fmt(row['rest_m'])} | {extra or '—'} | "
            f"{row['cpu_s']:.2f} | {row['rtf']:.3g} | {row['rtf_cpu']:.3g} | {_fmt(row.get('x_mujoco_cpu'), 1)} | "
            f"{steps} | "
            f"{'' if row['completed'] else row['stop'][:70]} |")


def collect(quick: bool = False, cases=(), match=(), refresh: bool = False, check: bool = False) -> dict:
    """Run every case at every setting (``cases``/``match`` filter them); return the JSON-ready results."""
    anchor = mujoco_anchor()
    out = {"quick": quick, "settings": {k: {"integrator": v[0], "dt": v[1]} for k, v in SETTINGS.items()},
           "anchor_before": anchor, "cases": {}, "rows": []}
    if anchor:
        print(f"speed anchor: MuJoCo 10-module screw snake, implicitfast 10 ms: RTF {anchor['rtf_wall']:.3g} wall, "
              f"{anchor['rtf_cpu']:.3g} CPU")
    for name, case in CASES.items():
        if cases and name not in cases:
            continue
        duration = case["durations"][0 if quick else 1]
        t0 = time.perf_counter()
        ref = reference(name, case, duration, refresh)
        info = {"duration_s": duration, "reference": {"integrator": case["ref"][0], "dt": case["ref"][1],
                                                       "stop": ref.summary["stop_reason"]}}
        if case["kind"] == "wall":
            info["offset"] = ev.wall_offset(case["scene"])[1]
        line = f"\n### {name} ({duration:g} s; reference {_label(*case['ref'])}"
        if case["kind"] == "bounce":
            info["reference"]["apex_m"] = bounce_apex(ref)
            line += f", its first bounce's apex {bounce_apex(ref) * 1e3:.2f} mm above the release"
        if case["kind"] == "free":
            info["reference"]["drift_per_s"] = ev.invariant_drift(ref)
        if check:
            other = reference(name, case, duration, spec=case["check"])
            info["reference"]["check"] = {"setting": _label(*case["check"]), "end_offset_m": end_offset(other, ref)}
            line += f"; {_label(*case['check'])} moves its end pose by {end_offset(other, ref) * 1e3:.3g} mm"
            if case["kind"] == "bounce":
                info["reference"]["check"]["apex_diff_m"] = abs(bounce_apex(other) - bounce_apex(ref))
                line += f" (mid-bounce) and its apex by {abs(bounce_apex(other) - bounce_apex(ref)) * 1e3:.3g} mm"
            if case["kind"] == "crawl":
                info["reference"]["check"]["tail_diff_m"] = tail_error(other, ref)
                line += f", its tail track by {tail_error(other, ref) * 1e3:.3g} mm"
        print(line + f"; ready in {time.perf_counter() - t0:.0f} s)")
        if case["kind"] == "wall":
            o = info["offset"]
            print(f"robot moved {o['offset_m'] * 1e3:.3f} mm along {np.round(o['normal'], 4).tolist()}: "
                  + ", ".join(f"{k} {v['depth_m'] * 1e3:.2f} mm deep" + (" -> 0.5 mm off" if v["off_wall"] else
                                                                        " -> deeper")
                              for k, v in o["screws"].items()))
        print("| setting | completed | rise mm | rest mm | case measure | CPU s | RTF | RTF CPU | x MuJoCo CPU | "
              "steps / rejected / h_min s | stop |\n|---|---|---:|---:|---|---:|---:|---:|---:|---|---|", flush=True)
        out["cases"][name] = info
        for label, (integ, dt) in SETTINGS.items():
            if match and not any(m in label for m in match):
                continue
            try:
                rec = Recorded.of(case["run"](integ, dt, duration))
            except Exception as e:                 # a build a setting is refused at: reported, not fatal
                print(f"| {label} | build error | | | | | | | | {type(e).__name__}: {str(e)[:60]} |")
                out["rows"].append({"case": name, "setting": label, "error": f"{type(e).__name__}: {e}"})
                continue
            row = {"setting": label, **measure(name, case, rec, ref)}
            if anchor:
                row["x_mujoco_cpu"] = row["rtf_cpu"] / anchor["rtf_cpu"]
            print(row_line(label, row), flush=True)
            out["rows"].append(row)
    out["anchor_after"] = mujoco_anchor()
    return out


def _label(integ, dt) -> str:
    if integ is None:
        return "scene"
    p = integ.get("params", {})
    if integ["name"] == "rosenbrock_w":
        d = RosenbrockWParams().model_dump(mode="json")
        p = {k: v for k, v in p.items() if d.get(k) != v}
    return f"{integ['name']} dt={dt:g}" + "".join(f" {k}={v}" for k, v in p.items())


# -- figure --------------------------------------------------------------------------------------------------------

def plot(results: dict, path: Path) -> None:
    """CPU time against the case's accuracy figure, one panel per case; failed runs along the top edge."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [n for n in results["cases"]]
    cols = 3
    rows_n = max(1, math.ceil(len(names) / cols))
    fig, axes = plt.subplots(rows_n, cols, figsize=(5.2 * cols, 4.0 * rows_n), squeeze=False)
    labels = list(results["settings"])
    colors = {s: plt.cm.tab10(i % 10) for i, s in enumerate(labels)}
    for ax, name in zip(axes.flat, names):
        rows = [r for r in results["rows"] if r["case"] == name and "error" not in r]
        ok = [r for r in rows if r["error_m"] is not None]
        top = max([r["error_m"] for r in ok] + [1e-3]) * 3
        for r in rows:
            y = max(r["error_m"], 1e-7) if r["error_m"] is not None else top
            ax.scatter(r["cpu_s"], y, color=colors[r["setting"]], marker="o" if r["error_m"] is not None else "x",
                       s=30, label=r["setting"])
        ax.axhline(5e-3, color="0.6", lw=0.8, ls=":")
        ax.set_xscale("log"), ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        kind = _measure_name(rows)
        ax.set_title(f"{name} ({results['cases'][name]['duration_s']:g} s)", fontsize=9)
        ax.set_xlabel("CPU s (step loop)")
        ax.set_ylabel(f"{kind}, m (x: failed)", fontsize=8)
        ax.grid(True, which="both", lw=0.3)
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    handles = [plt.Line2D([], [], color=colors[s], marker="o", ls="") for s in labels]
    fig.legend(handles, labels, loc="lower center", ncol=min(4, len(labels)), fontsize=7)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def _measure_name(rows) -> str:
    for key, name in (("apex_err_m", "bounce apex error"), ("tail_err_m", "tail error"), ("rest_m", "end pose error")):
        if any(key in r for r in rows):
            return name
    return "error"


def write(results: dict, json_path: str | None, plot_path: str | None) -> None:
    if json_path:
        Path(json_path).parent.mkdir(parents=True, exist_ok=True)
        Path(json_path).write_text(json.dumps(results, indent=1, default=str) + "\n")
        print(f"\nwrote {json_path}")
    if plot_path:
        plot(results, Path(plot_path))
        print(f"wrote {plot_path}")


@click.command()
@click.option("--quick", is_flag=True, help="Shorter runs (a few minutes on 2 cores).")
@click.option("--case", "cases", multiple=True, type=click.Choice(list(CASES)), help="Only these cases.")
@click.option("--setting", "match", multiple=True, help="Only the settings whose label contains this text.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), default=str(RESULTS / "events.json"),
              show_default=True)
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False), default=str(RESULTS / "events.png"),
              show_default=True)
@click.option("--refresh-references", "refresh", is_flag=True, help="Recompute the cached references.")
@click.option("--check-references", "check", is_flag=True,
              help="Also run each reference at half its step (or a 10x tighter tolerance) and print the difference.")
def main(quick, cases, match, json_path, plot_path, refresh, check):
    results = collect(quick, cases, match, refresh, check)
    write(results, json_path, plot_path)


if __name__ == "__main__":
    main()
