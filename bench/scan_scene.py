"""The scanned terrain's speed/accuracy knobs where a user feels them: the scene scan-moulin-brace-down.

The mesh terrain kind trades speed for accuracy with the SDF grid's spacing (``resolution``) and
``exact_band`` (m: where the grid's |d| < band the exact point–triangle distance is used;
components/terrain/mesh_exact.py). bench/mesh_sdf_query.py measures them per query; this runs the whole scene
(EELS 1.5 braced at 3.5 m in the scanned moulin: a >= 10 s hold, then a diagonal descent from 11 s) on
variants of terrains/moulin-slot-scan.yaml and on its analytic truth (``--terrain moulin-slot``).

Each variant is a copy of the shipped terrain YAML in a temporary folder, pointing at the same .ply (absolute
path) with other knob values (``--variants RES:BAND,...``; default: resolution 0.03 m with band 0, 0.03,
0.06 m (the shipped one), 0.015 m without the band, and 0.06 m with a 0.06 m band). All grids go to a private
terrain store (a temporary folder, or ``--store DIR``; passed to the runs as $SNAKESIM_TERRAIN_STORE), so the
user's cache is neither used nor filled. Each variant's store entries are built first, in this process, and
timed on their own (the variants share a store in the listed order, so a variant whose grid is already there
pays only its band). Then each scene runs as a user runs it, one process each:

    snakesim run scan-moulin-brace-down --terrain FILE --duration D --out DIR

From summary.json and signals.csv: the real-time factor (the summary's: sim time / wall time of the run),
the run's wall time, the process's start-up + build (process wall time less the run's: imports, the
placement's survey and fits, the terrain read from the store), the longest hold within 5 mm and the tail's
drift until climb_start (max |p(t) − p(0)|), the descent (the evaluation's ``down_m``, tail), the failure,
the deepest penetration of a watched link (clearance), and the largest distance over time between the
robot's centre of mass and the truth run's (and the tail's), on the common recorded times; as the placement
surveys each terrain, the runs start apart: also that offset (COM Δ0) and the largest difference of the COM's
displacement from its own start (path Δ: the motion without the placement's offset).

    .venv/bin/python bench/scan_scene.py [--duration 14] [--quick] [--variants 0.03:0,0.03:0.06]
                                         [--store DIR] [--keep] [--json bench/results/scan_scene.json]

The temporary folder is removed at the end (``--keep`` keeps it). ``--quick``: 3 s simulated (placement and the
start of the hold), variants 0.03:0 and 0.03:0.06 only; ~1 min.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
SCENE = "scan-moulin-brace-down"
SCAN = ROOT / "terrains" / "moulin-slot-scan.yaml"
TRUTH = "moulin-slot"
CLIMB_START = 11.0        # s, the scene's climb_start: the hold's end
DEFAULT_VARIANTS = "0.03:0,0.03:0.03,0.03:0.06,0.015:0,0.06:0.06"
QUICK_VARIANTS = "0.03:0,0.03:0.06"


def variant_file(folder: Path, resolution: float, band: float) -> Path:
    """The shipped scan's terrain YAML with other knob values, its mesh named by absolute path."""
    spec = yaml.safe_load(SCAN.read_text())
    spec.update(file=str((SCAN.parent / spec["file"]).resolve()), resolution=resolution, exact_band=band,
                description=f"{spec['description']}: resolution {resolution:g} m, exact_band {band:g} m")
    path = folder / f"scan-r{resolution:g}-b{band:g}.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False))
    return path


def build_store(path: Path, store: Path) -> float:
    """Seconds to build (or read) the variant's grid and band into the store."""
    from snakesim.components.terrain import load_terrain

    t0 = time.perf_counter()
    load_terrain(str(path), store=store)
    return time.perf_counter() - t0


def run_scene(terrain: str, duration: float, out: Path, store: Path) -> dict:
    """One `snakesim run` in its own process; the summary, the recorded tail and COM, the process's wall time."""
    cmd = [str(Path(sys.executable).with_name("snakesim")), "run", SCENE, "--terrain", terrain,
           "--duration", str(duration), "--out", str(out), "--overwrite", "--quiet"]
    env = dict(os.environ, SNAKESIM_TERRAIN_STORE=str(store))
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    if not (out / "summary.json").is_file():
        raise RuntimeError(f"{' '.join(cmd)} wrote no summary (exit {proc.returncode}):\n{proc.stderr[-3000:]}")
    summary = json.loads((out / "summary.json").read_text())
    with open(out / "signals.csv", newline="") as f:
        rows = list(csv.reader(f))
    head, data = rows[0], np.array(rows[1:], dtype=float)
    col = {name: i for i, name in enumerate(head)}
    pick = lambda prefix: data[:, [col[f"{prefix}.{a}"] for a in "xyz"]]   # noqa: E731
    return {"summary": summary, "process_wall_s": wall, "exit": proc.returncode, "t": data[:, col["t"]],
            "com": pick("robot.com"), "tail": pick("robot.link_poses.tail")}


def max_gap(a: dict, b: dict, key: str, relative: bool = False) -> float:
    """Largest |a − b| of a recorded position over the times both runs recorded (m); ``relative``: of the
    displacements from each run's own start (the path, without the placement's offset)."""
    n = min(len(a["t"]), len(b["t"]))
    if not np.allclose(a["t"][:n], b["t"][:n]):
        raise RuntimeError("the runs recorded at different times")
    pa, pb = a[key][:n], b[key][:n]
    if relative:
        pa, pb = pa - pa[0], pb - pb[0]
    return float(np.linalg.norm(pa - pb, axis=1).max())


def figures(r: dict, truth: dict | None) -> dict:
    s = r["summary"]
    ev, cl = s["reports"]["evaluation"], s["reports"]["clearance"]
    hold = r["t"] <= CLIMB_START
    fail = ev["failure"]
    out = {"rtf": s["real_time_factor"], "run_wall_s": s["wall_time_s"], "sim_s": s["sim_time_s"],
           "startup_build_s": r["process_wall_s"] - s["wall_time_s"], "outcome": s["outcome"],
           "stop_reason": s["stop_reason"], "exit": r["exit"],
           "hold_longest_s": ev["hold"]["longest_s"],
           "hold_drift_m": float(np.linalg.norm(r["tail"][hold] - r["tail"][0], axis=1).max()),
           "down_m": ev["vertical_distance"]["down_m"],
           "failure": fail["reason"] if fail["failed"] else None,
           "deepest_penetration_m": cl["max_depth_m"]}
    if truth is not None:
        out["com_start_vs_truth_m"] = float(np.linalg.norm(r["com"][0] - truth["com"][0]))
        out["com_vs_truth_max_m"] = max_gap(r, truth, "com")
        out["com_path_vs_truth_max_m"] = max_gap(r, truth, "com", relative=True)
        out["tail_vs_truth_max_m"] = max_gap(r, truth, "tail")
    return out


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=14.0, help="simulated s (hold to 11 s, then descent)")
    ap.add_argument("--quick", action="store_true", help="3 s, two variants: a smoke run")
    ap.add_argument("--variants", default=None, help=f"RES:BAND,... in m (default {DEFAULT_VARIANTS})")
    ap.add_argument("--store", default=None, help="terrain store (default: in the temporary folder: builds timed)")
    ap.add_argument("--keep", action="store_true", help="keep the temporary folder (variants, runs, store)")
    ap.add_argument("--json", default="bench/results/scan_scene.json")
    a = ap.parse_args(argv)
    duration = 3.0 if a.quick else a.duration
    spec = a.variants or (QUICK_VARIANTS if a.quick else DEFAULT_VARIANTS)
    try:
        knobs = [tuple(float(v) for v in item.split(":")) for item in spec.split(",")]
    except ValueError:
        knobs = []
    if not knobs or any(len(k) != 2 for k in knobs):
        ap.error(f"--variants {spec!r}: expected RES:BAND,... in m, e.g. 0.03:0,0.03:0.06")

    folder = Path(tempfile.mkdtemp(prefix="scan_scene_"))
    try:
        measure(a, knobs, duration, folder)
    finally:
        if not a.keep:                          # the default variants' store is ~180 MB
            shutil.rmtree(folder, ignore_errors=True)


def measure(a, knobs, duration: float, folder: Path):
    store = Path(a.store) if a.store else folder / "store"
    print(f"scene {SCENE}, {duration:g} s simulated; terrain variants and runs in {folder}, store {store}",
          flush=True)
    variants = []
    for res, band in knobs:
        path = variant_file(folder, res, band)
        t_store = build_store(path, store)
        print(f"  store: resolution {res:g} m, exact_band {band:g} m: {t_store:.1f} s", flush=True)
        variants.append({"terrain": f"scan r {res:g} band {band:g}", "resolution_m": res, "exact_band_m": band,
                         "store_build_s": t_store, "file": str(path)})

    truth = run_scene(TRUTH, duration, folder / "run-truth", store)
    rows = [{"terrain": f"{TRUTH} (truth)", "resolution_m": None, "exact_band_m": None, "store_build_s": None,
             **figures(truth, None)}]
    print(f"  ran {rows[0]['terrain']}", flush=True)
    for k, v in enumerate(variants):
        r = run_scene(v.pop("file"), duration, folder / f"run-{k}", store)
        rows.append({**v, **figures(r, truth)})
        print(f"  ran {v['terrain']}", flush=True)

    cell = lambda x, f, w: "—".rjust(w) if x is None else format(x, f"{w}{f}")   # noqa: E731
    mm = lambda r, key: None if r.get(key) is None else 1e3 * r[key]          # noqa: E731
    print(f"\n{'terrain':24s} {'store s':>7s} {'start+build s':>13s} {'run s':>6s} {'RTF':>5s} {'hold s':>6s} "
          f"{'drift mm':>8s} {'down m':>6s} {'deepest mm':>10s} {'COM Δ0 mm':>9s} {'COM Δ mm':>8s} "
          f"{'path Δ mm':>9s} {'tail Δ mm':>9s}  failure")
    for r in rows:
        print(f"{r['terrain']:24s} {cell(r['store_build_s'], '.1f', 7)} {r['startup_build_s']:13.1f} "
              f"{r['run_wall_s']:6.1f} {r['rtf']:5.2f} {r['hold_longest_s']:6.2f} {mm(r, 'hold_drift_m'):8.2f} "
              f"{r['down_m']:6.3f} {mm(r, 'deepest_penetration_m'):10.2f} "
              f"{cell(mm(r, 'com_start_vs_truth_m'), '.1f', 9)} {cell(mm(r, 'com_vs_truth_max_m'), '.1f', 8)} "
              f"{cell(mm(r, 'com_path_vs_truth_max_m'), '.1f', 9)} {cell(mm(r, 'tail_vs_truth_max_m'), '.1f', 9)}"
              f"  {r['failure'] or r['outcome']}")
    out = {"scene": SCENE, "duration_s": duration, "climb_start_s": CLIMB_START, "cores": os.cpu_count(),
           "rows": rows}
    if a.json:
        Path(a.json).parent.mkdir(parents=True, exist_ok=True)
        Path(a.json).write_text(json.dumps(out, indent=2))
        print(f"wrote {a.json}")


if __name__ == "__main__":
    main(sys.argv[1:])
