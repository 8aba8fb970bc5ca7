"""The validation report: every analytic / physics check of the project in one table, plus the
45 s crescent traverse against its tight reference (the fig. 14 quantities).

    .venv/bin/python bench/validation_report.py [--no-traverse] [--json FILE]

Part 1 runs pytest on the checks listed in CHECKS (each test module is one group: its
docstrings say which closed form, conservation law or model prediction it compares with) and
prints one row per test with its outcome. Nothing is re-implemented here: the tests are the
checks. Part 2 runs the default scene for its full 45 s at a few settings and prints, for each,
the max tail x, y and yaw error against the reference (rk4, dt = 0.25 ms, cached in
bench/results/), with the paper's model-vs-hardware error for scale (4 cm, 0.06 rad). Part 3
runs the vertical-mobility scenes (bench/vertical_mobility.py's list: the successes and the
failure variant) and prints each one's field-test evaluation (paper 4.3.1: contact, static hold,
vertical distance, failure and its reason, tether slack) and the bodies the scene lets into the
terrain (terrain_clearance).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import click
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "validation"))
from validation_scenes import REFERENCE, TRAVERSE, reference_track, run, tail_track  # noqa: E402

CHECKS = {  # test module -> what it checks against
    "tests/framework/test_integrators.py": "integrator order and exact solutions",
    "tests/multibody/test_conservation.py": "momentum / energy conservation of the multibody",
    "tests/multibody/test_screw_pairs.py": "screw-pair models (embedded vs mimic) agree",
    "tests/contact/test_steady_state.py": "screw steady axial speed, closed form",
    "tests/contact/test_screw_sdf_scenes.py": "whole stack: u*, friction-angle creep and slide",
    "tests/terrain/test_analytic.py": "terrain signed distances against geometry",
    "tests/tethers/test_tethers.py": "tether statics and rope behaviour",
    "tests/control/test_pid.py": "PID closed-loop responses",
    "tests/monitors/test_mobility.py": "mobility monitor tilt and metrics",
    "tests/validation/test_traverse.py": "default scene: motion direction per screw combination, reference error",
    "tests/validation/test_scenes.py": "scenes: dangling tension = weight, climb failure stop, support",
    "tests/monitors/test_vertical_mobility.py": "field-test evaluation against scripted runs",
    "tests/control/test_brace_climb.py": "brace: Σ friction along gravity = weight, rolling at ω r, climb/descent",
    "tests/validation/test_fts_braced.py": "FTS = −(distal contact forces + weight) by Newton, braced",
    "tests/validation/test_u_channel_traverse.py": "U-channel traverse at the screws' analytic steady speed",
    "tests/control/test_pipe_climb.py": "Mini EELS pipe climb: per-cycle gain vs no-slip roll, step convergence",
    "tests/contact/test_body_contact.py": "body contact: F/k sink, slope slide/creep, anisotropy, vs hull back end",
    "tests/contact/test_screw_sdf_curved.py": "curved terrain: sink F/k at every roll and spin angle",
    "tests/multibody/test_articulated_solve.py": "O(N) implicit solve = dense solve; tree dynamics = Pinocchio ABA",
    "tests/multibody/test_joint_stops.py": "joint stops: static deflection τ/k, energy through an impact, implicit J",
    "tests/validation/test_moulin_brace_down.py": "moulin down-climb: hold, descent at ω r sin β, tether slack",
    "tests/validation/test_tube_body_brace.py": "tube body brace: Σ F_z = m g, hold, clearance and limits",
    "tests/validation/test_tube_body_brace_descend.py": "tube friction descent: speed = command, μ ΣF_n = m g, re-grip",
    "tests/validation/test_u_channel_body_brace.py": "U-channel body brace: rolls at ω r, Σ F_z = m g, bodies clear",
}


def run_checks() -> list[dict]:
    present = [p for p in CHECKS if (ROOT / p).exists()]
    with tempfile.TemporaryDirectory() as d:
        xml = Path(d) / "junit.xml"
        subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--continue-on-collection-errors",
                        f"--junitxml={xml}", *present],
                       cwd=ROOT, capture_output=True, text=True)
        rows = []
        for case in ET.parse(xml).getroot().iter("testcase"):
            outcome = "passed"
            for tag in ("failure", "error", "skipped"):
                if case.find(tag) is not None:
                    outcome = tag
            cls = case.get("classname", "").replace(".", "/")
            file = next((p for p in present if cls.startswith(p[:-3])), cls)
            rows.append({"file": file, "test": case.get("name"), "outcome": outcome, "time_s": float(case.get("time", 0))})
    return rows


TRAVERSE_SETTINGS = [("rosenbrock_w", 2.5e-3, {"method": "ros2", "jacobian_every": 3}),     # the scene's own
                     ("rk4", 1e-3, {}), ("rk4", 2e-3, {}), ("semi_implicit_euler", 5e-4, {}),
                     ("semi_implicit_euler", 1e-3, {}), ("dopri5", 1e-3, {"rtol": 1e-4, "atol": 1e-6})]


def traverse_rows() -> list[dict]:
    t_ref, ref = reference_track(45.0)
    rows = []
    for name, dt, p in TRAVERSE_SETTINGS:
        _, r = run(TRAVERSE, [], {"duration": 45.0, "dt": dt, "integrator": {"name": name, "params": p}})
        t, pose = tail_track(r)
        n = min(len(t), len(t_ref))
        d = pose[:n] - ref[:n]               # both recorded at the scene's 50 Hz
        rows.append({"setting": f"{name} dt={dt:g}" + "".join(f" {k}={v}" for k, v in p.items()),
                     "x_err_m": float(np.abs(d[:, 0]).max()), "y_err_m": float(np.abs(d[:, 1]).max()),
                     "yaw_err_rad": float(np.abs(d[:, 2]).max()), "rtf": r.summary["real_time_factor"],
                     "stop": r.summary["stop_reason"]})
    return rows


def vertical_rows() -> list[dict]:
    sys.path.insert(0, str(ROOT / "bench"))
    from vertical_mobility import SCENES, measure

    rows = []
    for scene in SCENES:
        row, _s, r = measure(scene)
        row["clearance"] = r.summary.get("reports", {}).get("clearance")
        rows.append(row)
    return rows


def _inside(cl: dict | None) -> str:
    if cl is None:
        return "not watched"
    return ", ".join(f"{k} {1e3 * v:.0f} mm" for k, v in list(cl["inside"].items())[:3]) or "none"


def _evaluation_line(row: dict) -> str:
    ev, cl = row["evaluation"], row.get("clearance")
    if not ev:
        return f"| {row['scene']} | — | — | — | — | {row['stop_reason']} | — |"
    if "contact" not in ev:             # a traverse_evaluation (u-channel-brace-traverse): distance along the path
        return (f"| {row['scene']} | — | — | {ev.get('distance_m', float('nan')):+.3g} m along the channel, steady "
                f"{ev.get('steady_speed_m_s') or float('nan'):.3g} m/s | none | {row['stop_reason']} | "
                f"{_inside(cl)} |")
    c, h, d, f = ev["contact"], ev["hold"], ev["vertical_distance"], ev["failure"]
    inside = _inside(cl)
    tether = f"; tether slack {100 * ev['tether']['slack_fraction']:.0f} %" if "tether" in ev else ""
    return (f"| {row['scene']} | {c['time_s'] if c['made'] else 'never'} | {h['longest_s']:.3g} s "
            f"({'held' if h['achieved'] else 'not held'}) | +{d['up_m']:.3g} / −{d['down_m']:.3g} m | "
            f"{f['reason'] if f['failed'] else 'none'}{tether} | {row['stop_reason']} | {inside} |")


@click.command()
@click.option("--no-traverse", is_flag=True, help="Skip the 45 s traverse comparison.")
@click.option("--no-vertical", is_flag=True, help="Skip the vertical-mobility scenes.")
@click.option("--json", "json_path", type=click.Path(dir_okay=False))
def main(no_traverse, no_vertical, json_path):
    rows = run_checks()
    print("| check | test | outcome | s |\n|---|---|---|---:|")
    for r in rows:
        print(f"| {CHECKS.get(r['file'], r['file'])} | {r['test']} | {r['outcome']} | {r['time_s']:.2f} |")
    bad = [r for r in rows if r["outcome"] in ("failure", "error")]
    print(f"\n{len(rows) - len(bad)} of {len(rows)} checks pass" + (f"; FAILING: {[r['test'] for r in bad]}" if bad else ""))
    out = {"checks": rows}
    if not no_traverse:
        print(f"\n45 s crescent traverse against the reference ({REFERENCE['integrator']}, dt = {REFERENCE['dt']:g} s); "
              "paper 4.2, model vs hardware: 0.04 m, 0.06 rad\n")
        print("| setting | max tail x err m | max tail y err m | max yaw err rad | RTF | stop |\n|---|---:|---:|---:|---:|---|")
        tr = traverse_rows()
        for r in tr:
            print(f"| {r['setting']} | {r['x_err_m']:.2e} | {r['y_err_m']:.2e} | {r['yaw_err_rad']:.2e} | {r['rtf']:.3g} | {r['stop']} |")
        out["traverse"] = tr
    if not no_vertical:
        print("\nVertical mobility (paper 4.3.1's evaluation, each scene at its production step)\n")
        print("| scene | contact s | longest hold | up / down | failure | run's stop | bodies inside the terrain |\n"
              "|---|---|---|---|---|---|---|")
        vr = vertical_rows()
        for r in vr:
            print(_evaluation_line(r))
        out["vertical"] = vr
    if json_path:
        Path(json_path).write_text(json.dumps(out, indent=1) + "\n")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
