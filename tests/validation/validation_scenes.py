"""Helpers shared by the validation tests, the validation report and the benches: run a scene
with overrides and read the tail trajectory; the traverse reference run and its cache."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from snakesim.framework.session import Session
from snakesim.framework.assembly import resolve
from snakesim.framework.registry import default_registry

REPO = Path(__file__).resolve().parents[2]
CACHE = REPO / "bench" / "results"
TRAVERSE = "surface-screw-traverse"
#: the tight reference setting of the traverse: small step, 4th order
REFERENCE = {"integrator": "rk4", "dt": 2.5e-4, "params": {}}


def session(scene: str, sets=(), sim=None, patch=None) -> Session:
    """Resolve ``scene`` with ``--set`` items and sim flags; ``patch(resolved)`` edits it before the build."""
    reg = default_registry()
    resolved = resolve(scene, search_path=reg.assembly_paths(), overrides=list(sets), sim_overrides=sim or {})
    if patch is not None:
        patch(resolved)
    return Session(resolved, reg)


def run(scene: str, sets=(), sim=None, patch=None):
    s = session(scene, sets, sim, patch)
    return s, s.run()


def tail_track(result) -> tuple[np.ndarray, np.ndarray]:
    """(t, [x, y, unwrapped yaw]) of the recorded tail pose."""
    pose = np.array(result["tail_pose.pose"], dtype=float)
    pose[:, 2] = np.unwrap(pose[:, 2])
    return np.array(result["t"]), pose


def track_error(t, pose, t_ref, pose_ref) -> dict:
    """Max |position| and |yaw| error of a track against the reference, on the reference's times
    up to the end of the shorter one (a run that stopped early is compared where it exists)."""
    end = min(t[-1], t_ref[-1])
    keep = t_ref <= end + 1e-9
    tr = t_ref[keep]
    interp = np.column_stack([np.interp(tr, t, pose[:, j]) for j in range(3)])
    d = interp - pose_ref[keep]
    return {"pos_err_m": float(np.max(np.hypot(d[:, 0], d[:, 1]))), "yaw_err_rad": float(np.max(np.abs(d[:, 2])))}


def reference_track(duration: float, sets=(), scene: str = TRAVERSE, refresh: bool = False):
    """The traverse at the reference setting, cached in bench/results (one file per scene/horizon/sets)."""
    key = f"{scene}-{duration:g}s" + ("-" + "-".join(s.replace("=", "_") for s in sets) if sets else "")
    path = CACHE / f"reference-{key}.npz"
    meta = {"scene": scene, "duration": duration, "sets": list(sets), **REFERENCE}
    if path.exists() and not refresh:
        z = np.load(path, allow_pickle=False)
        if json.loads(str(z["meta"])) == meta:
            return z["t"], z["pose"]
    _, r = run(scene, sets, {"duration": duration, "dt": REFERENCE["dt"], "integrator": REFERENCE["integrator"]})
    if not r.summary["completed"]:
        raise RuntimeError(f"reference run of {scene} did not complete: {r.summary['stop_reason']}")
    t, pose = tail_track(r)
    CACHE.mkdir(parents=True, exist_ok=True)
    np.savez(path, t=t, pose=pose, meta=json.dumps(meta))
    return t, pose


def assert_bodies_clear_and_within_limits(s, r, robot, depth: float = 0.005) -> None:
    """A body-respecting scene's run: joint stops on, no link deeper than ``depth`` m in the terrain (its
    terrain_clearance report), every bend and twist inside its URDF limits throughout."""
    assert s.plan.components["robot"]._stops is not None                 # joint stops on
    cl = r.summary["reports"]["clearance"]
    assert cl["inside"] == {} and cl["max_depth_m"] <= depth
    lo, hi = robot.position_limits()
    q = r["robot.joint_q"]
    for k, kind in enumerate(robot.joint_kinds):
        if kind in ("bend", "twist"):
            assert lo[k] <= q[:, k].min() and q[:, k].max() <= hi[k], robot.joints[k]
