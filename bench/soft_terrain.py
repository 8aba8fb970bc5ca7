"""Screws on soft terrain (issue 29): the classic terramechanics curves and the soil contact's cost.

    .venv/bin/python bench/soft_terrain.py [--quick] [--json FILE] [--png FILE]

1. Drawbar pull against slip, one EELS 1.0 module (its two counter-rotating screws, 3 rad/s) on the snow
   field: a towing force F opposing the motion; at steady state the screws' thrust balances it, so the
   steady slip under F is where the thrust curve T(s) meets F. The module's weight sets the sinkage (the
   height where the soil carries it: bisection on the contact kernel's normal force, virgin snow); T(s)
   is the kernel's axial force at that height, the towing forces' slips found by bisection on T(s) = F.
   Quasi-static (the screw's height and spin held), so it shows the soil law's curve, not a transient.
   Beside it, dynamic: the snow-drawbar-pull scene as a user runs it at each towing force (the module on its
   drawbar_carriage in a 1 cm snow bin, integrated for 3 s): the carriage's steady slip and the run's speed;
   and driven at set slips (--quick: three), braking to near stall: the carriage's drawbar pull.
2. Speed against screw rate: the forward phase of snow-screw-traverse (snow, terramechanics_contact) and of
   surface-screw-traverse (hard ice, terrains/flat-ice.yaml, screw_sdf_contact), each at its own sim
   settings; the tail's mean speed along the crescent's chord (+x) over the phase's last half.
3. Cost per step against the snow grid's cell: snow-screw-traverse for a few seconds with the snow field's
   cell set to each value (its own settings: rosenbrock_w, 20 ms); wall time per step and real-time factor;
   and the same snow on a DEM base (terrains/snow-dem.yaml, 2 cm: the law along the ground's normal) and
   with bulldozing (berms heaped and eroded, terrain/bulldozing.py).
4. The whole schedule (45 s; --quick: the settle and the forward phase, 9 s) on snow and on hard ice: the
   distance made good (the tail's displacement) and its path length; the snow run's rut saved beside the
   results (soft_terrain.terrain.npz, components/terrain/deformable_files.py; soft_terrain.rut.png).
5. A rigid wheel (r 0.3 m, b 0.15 m, 500 N) on dry sand (terrains/sand-field.yaml's soil; the textbook case,
   components/terramechanics/wheel.py): at each slip the sinkage where the soil carries the load (bisection),
   then the drawbar pull and the driving torque (tests/terramechanics/test_rigid_wheel.py checks the same
   against Wong's integrals).
6. Shape gaits on soil (soil_body_contact): mini-eels-sand-crawl and regolith-sidewinding at their own
   settings (--quick: 5 s, else 20 s), each with its shipped skin, Mohr–Coulomb alone and the rut walls'
   passive pressure: the centre of mass's displacement, the rut and the real-time factor.
7. Held still on a slope: EELS 1.0 with idle screws on the snow laid on a 5° plane; the creep after settling
   against the shear's v_eps and the step (the scene's error control, fixed 20 ms, fixed 10 ms).
8. The step on snow: snow-screw-traverse's whole schedule (45 s; --quick: 9 s) with the scene's error control
   and with fixed steps, the tail against fixed 2 ms steps (1 cm from 1 ms), and the forward phase's speed at
   1 rad/s (a Jacobian kept for 8 fixed 20 ms steps ran it backwards).

Writes bench/results/soft_terrain.json and bench/results/soft_terrain.png (or the given files). --quick:
fewer points and shorter runs (under a minute on 2 shared cores).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from snakesim.framework.session import load_session

RESULTS = Path(__file__).with_name("results")
ROOT = Path(__file__).resolve().parents[1]
G = 9.81
OMEGA = 3.0                      # rad/s, the scenes' screw_speed


# -- 1. drawbar pull against slip -------------------------------------------------------------------------
def module_screws():
    """(screw geometry rows of one module's pair, the module's weight N) from the snow scene's robot."""
    s = load_session("snow-screw-traverse", sim_overrides={"duration": 0.02})
    contact = s.plan.components["contact"]
    lay = contact.screws
    model = s.plan.components["robot"].dyn.model
    weight = sum(i.mass for i in model.inertias) * G / (lay.ns // 2)
    pair = [0, 1]
    geo = np.array([[lay.radius[k], lay.length[k], lay.lead_angle[k], float(lay.hand[k]), 1.0] for k in pair])
    return geo, weight, [lay.names[k] for k in pair]


class PairRig:
    """One module's two screws, axes along +x side by side (0.25 m apart), on fresh snow, each spinning at
    ±ω by its hand so that both push the same way; the kernel evaluated directly (no integration)."""

    def __init__(self, geo, cell=0.01):
        from snakesim.components.terrain.deformable import DeformableTerrain
        from snakesim.components.terrain.spec import load_terrain
        from snakesim.components.terramechanics.kernels import SCRATCH_COLUMNS, scratch_rows

        spec = load_terrain("snow-field").soil_spec
        self.terrain = DeformableTerrain(0.0, (-1.0, -1.0), (2.0, 2.0), cell, spec, max_tiles=16)
        self.geo = geo.copy()
        self.rows = np.array([[0, 0, 0], [1, 1, 1]], dtype=np.int64)
        self.mount_R = np.stack([np.eye(3), np.eye(3)])
        self.mount_p = np.zeros((2, 3))
        self.r = float(geo[0, 0])
        self.scratch = np.zeros((scratch_rows(geo[:, 0], geo[:, 1], cell), SCRATCH_COLUMNS))
        # each screw's spin sign makes h ω > 0: both advance along +x
        self.joint_v = np.array([OMEGA * np.sign(geo[0, 3]), OMEGA * np.sign(geo[1, 3])])
        self.v_ideal = OMEGA * self.r * math.tan(float(geo[0, 2]))

    def forces(self, depth, slip):
        """(Σ normal force N, Σ axial thrust N) with the envelopes' bottoms ``depth`` m into the snow and
        the pair advancing at (1 − slip) of the ideal nut speed."""
        from snakesim.components.terramechanics.contact import NO_LOG
        from snakesim.components.terramechanics.kernels import NORMAL, THRUST, screw_soil

        z = self.r - depth
        poses = np.array([[0.0, -0.125, z, 0, 0, 0, 1.0], [0.0, 0.125, z, 0, 0, 0, 1.0]])
        vels = np.zeros((2, 6))
        vels[:, 0] = (1.0 - slip) * self.v_ideal
        st = self.terrain.state
        w, per, tot = np.zeros((2, 6)), np.zeros((2, 5)), np.zeros(2)
        dt_, dp, on = np.zeros((2, 6, 6)), np.zeros((2, 6, 6)), np.zeros(2, dtype=np.bool_)
        screw_soil(self.terrain.grid, self.terrain.base_z, self.terrain.soil, st.tile_of, st.plastic, st.yield_p,
                   st.lift, st.used, self.rows, self.geo, self.mount_R, self.mount_p, poses, vels, self.joint_v, 0.5,
                   0.01, False, *NO_LOG, self.scratch, w, per, tot, False, dt_, dp, on)
        return per[:, NORMAL].sum(), per[:, THRUST].sum()

    def sinkage(self, weight):
        lo, hi = 0.0, 2.0 * self.r
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            if self.forces(mid, 0.0)[0] < weight:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)


def drawbar(quick: bool) -> dict:
    geo, weight, names = module_screws()
    rig = PairRig(geo)
    depth = rig.sinkage(weight)
    slips = np.linspace(-0.2, 1.0, 7 if quick else 25)
    thrust = [rig.forces(depth, s)[1] for s in slips]
    # towing forces between the curve's ends; steady slip where T(s) = F (T rises with s past its minimum)
    smin = float(slips[int(np.argmin(thrust))])
    tows = np.linspace(0.0, 0.95 * max(thrust), 5 if quick else 10)
    steady = []
    for F in tows:
        lo, hi = smin, 1.0
        if rig.forces(depth, hi)[1] < F:
            steady.append(None)
            continue
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if rig.forces(depth, mid)[1] < F:
                lo = mid
            else:
                hi = mid
        steady.append(0.5 * (lo + hi))
    return {"screws": names, "module_weight_N": weight, "sinkage_m": depth, "omega_rad_s": OMEGA,
            "slip": slips.tolist(), "thrust_N": thrust, "towing_force_N": tows.tolist(), "steady_slip": steady,
            "dynamic": [towed(float(F)) for F in tows],
            "driven": [driven(float(sl), rig.v_ideal) for sl in ((-0.2, 0.3, 0.9) if quick else (-0.2, 0.0, 0.2, 0.4,
                                                                                                   0.6, 0.8, 0.9))],
            "max_drawbar_over_weight": max(thrust) / weight}


def driven(slip: float, v_nut: float) -> dict:
    """The snow-drawbar-pull scene with the carriage driving the module at (1 − slip) of the nut speed: the
    slip set, the drawbar pull measured (the carriage's report)."""
    r = load_session("snow-drawbar-pull", overrides=["tow=0", f"speed={(1.0 - slip) * v_nut}"]).run()
    rep = r.summary["reports"]["carriage"]
    return {"slip_set": slip, "slip": rep["slip"], "drawbar_pull_N": rep["drawbar_pull_N"],
            "real_time_factor": r.summary["real_time_factor"], "outcome": r.summary["outcome"]}


def towed(tow: float) -> dict:
    """The snow-drawbar-pull scene at ``tow`` N, as a user runs it: the carriage's steady slip and the run's
    speed (the module on its drawbar_carriage, integrated; the curve above is the kernel's alone)."""
    r = load_session("snow-drawbar-pull", overrides=[f"tow={tow}"]).run()
    rep = r.summary["reports"]["carriage"]
    return {"tow_N": tow, "slip": rep["slip"], "travel_speed_m_s": rep["travel_speed_m_s"],
            "real_time_factor": r.summary["real_time_factor"], "outcome": r.summary["outcome"]}


# -- 2. speed against screw rate --------------------------------------------------------------------------
def forward_speed(scene: str, rate: float, settle: float, phase: float) -> dict:
    s = load_session(scene, overrides=[f"screw_speed={rate}", f"settle={settle}", f"phase={phase}"],
                     sim_overrides={"duration": settle + phase})
    t0 = time.perf_counter()
    r = s.run()
    wall = time.perf_counter() - t0
    t, x = r["t"], r["tail_pose.pose"][:, 0]
    late = t >= settle + 0.5 * phase
    v = float(np.polyfit(t[late], x[late], 1)[0])
    return {"scene": scene, "screw_rate_rad_s": rate, "speed_m_s": v, "outcome": r.summary["outcome"],
            "real_time_factor": r.summary["real_time_factor"], "wall_s": wall}


def speeds(quick: bool) -> list[dict]:
    rates = [1.5, 3.0] if quick else [1.0, 2.0, 3.0, 4.0, 5.0]
    settle, phase = (0.5, 2.0) if quick else (1.0, 4.0)
    return [forward_speed(scene, w, settle, phase) for scene in ("snow-screw-traverse", "surface-screw-traverse")
            for w in rates]


# -- 3. cost per step against the grid's cell ----------------------------------------------------------
def cost(quick: bool) -> list[dict]:
    cells = [0.04, 0.02, 0.01] if quick else [0.04, 0.03, 0.02, 0.015, 0.01]
    duration = 2.0 if quick else 4.0
    text = (ROOT / "terrains" / "snow-field.yaml").read_text()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for cell in cells:
            path = Path(tmp) / f"snow-cell-{cell:g}.yaml"
            # max_tiles: the whole patch at this cell (untouched tiles cost no memory)
            tiles = math.ceil((20.0 / cell + 1) / 32) ** 2
            path.write_text(text.replace("cell: 0.02", f"cell: {cell}").replace("max_tiles: 1024",
                                                                                  f"max_tiles: {tiles}"))
            rows.append(_cost_row(str(path), cell, "plane", duration))
        rows.append(_cost_row("snow-dem", 0.02, "dem", duration))
        path = Path(tmp) / "snow-bulldozing.yaml"
        path.write_text(text + "bulldozing: {erosion_angle: 35.0, flow_factor: 1.0, erosion_iterations: 5}\n")
        rows.append(_cost_row(str(path), 0.02, "plane, bulldozing", duration))
    return rows


def _cost_row(terrain: str, cell: float, base: str, duration: float) -> dict:
    s = load_session("snow-screw-traverse", overrides=[f"terrain={terrain}", "settle=0.5"],
                     sim_overrides={"duration": duration})
    t0 = time.perf_counter()
    r = s.run()
    wall = time.perf_counter() - t0
    steps = r.summary["steps"]
    return {"cell_m": cell, "base": base, "steps": steps, "wall_s": wall, "us_per_step": wall / steps * 1e6,
            "real_time_factor": duration / wall, "outcome": r.summary["outcome"]}


def _shown(path: Path) -> str:
    """``path`` relative to the repository when inside it (the JSON is the same on every machine)."""
    p = Path(path).resolve()
    return str(p.relative_to(ROOT)) if p.is_relative_to(ROOT) else str(p)


# -- 4. the whole schedule, snow against ice; the rut -------------------------------------------------------
def traverse(quick: bool, json_path: Path) -> list[dict]:
    from snakesim.components.terrain.deformable_files import rut_picture, save_state

    duration = 9.0 if quick else 45.0
    rows = []
    for scene in ("snow-screw-traverse", "surface-screw-traverse"):
        s = load_session(scene, sim_overrides={"duration": duration})
        t0 = time.perf_counter()
        r = s.run()
        wall = time.perf_counter() - t0
        xy = r["tail_pose.pose"][:, :2]
        row = {"scene": scene, "duration_s": duration, "outcome": r.summary["outcome"], "wall_s": wall,
               "real_time_factor": duration / wall, "distance_made_good_m": float(np.hypot(*(xy[-1] - xy[0]))),
               "path_length_m": float(np.hypot(*np.diff(xy, axis=0).T).sum())}
        rep = (r.summary.get("reports") or {}).get("contact")
        if rep and "rut" in rep:
            terrain = s.plan.caches["contact"].terrain
            stem = json_path.with_suffix("")
            row["rut"] = rep["rut"]
            row["mean_sinkage_m"] = float(np.nanmean([v for v in rep["mean_sinkage_m"] if v is not None]))
            row["terrain_npz"] = _shown(save_state(terrain, stem.with_name(stem.name + ".terrain.npz")))
            pic = rut_picture(terrain, stem.with_name(stem.name + ".rut.png"),
                              title=f"{scene}: the rut after {duration:g} s")
            row["rut_png"] = _shown(pic) if pic else None
        rows.append(row)
    return rows


# -- 5. a rigid wheel on dry sand ---------------------------------------------------------------------------
def wheel(quick: bool) -> dict:
    from snakesim.components.terrain.deformable import DeformableTerrain
    from snakesim.components.terrain.spec import load_terrain
    from snakesim.components.terramechanics.wheel import RigidWheel, wheel_forces

    soil = load_terrain("sand-field").soil_spec
    t = DeformableTerrain(0.0, (-1.0, -1.0), (2.0, 2.0), 0.005, soil, max_tiles=16)
    w, load = RigidWheel(radius=0.3, width=0.15), 500.0
    rows = []
    for slip in np.linspace(0.0, 0.8, 5 if quick else 9):
        lo, hi = 0.0, 0.25
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if wheel_forces(t, w, (0.0, 0.0, w.radius - mid), 0.0, slip)["load"] > load else (mid, hi)
        f = wheel_forces(t, w, (0.0, 0.0, w.radius - 0.5 * (lo + hi)), 0.0, slip)
        rows.append({"slip": float(slip), "sinkage_m": 0.5 * (lo + hi), "drawbar_pull_N": f["drawbar_pull"],
                     "torque_Nm": f["torque"]})
    return {"radius_m": w.radius, "width_m": w.width, "load_N": load, "cell_m": 0.005, "rows": rows}


# -- 6. shape gaits on soil ------------------------------------------------------------------------------------
def shape_gaits(quick: bool) -> list[dict]:
    """Each gait scene with its own lateral resistance (the ``skin`` it ships with), with Mohr–Coulomb alone
    (skin 1, 1) and with the rut walls' passive pressure instead of a fitted factor (skin 1, 1 + rut_walls)."""
    variants = {"own skin": [], "skin 1, 1": ["skin.across=1.0"], "rut walls": ["skin.across=1.0", "rut_walls=true"]}
    rows = []
    for scene in ("mini-eels-sand-crawl", "regolith-sidewinding"):
        for label, overrides in variants.items():
            s = load_session(scene, overrides=overrides, sim_overrides={"duration": 5.0 if quick else 20.0})
            r = s.run()
            com = r["robot.com"]
            rep = r.summary["reports"]["contact"]
            rows.append({"scene": scene, "lateral": label, "duration_s": r.summary["sim_time_s"],
                         "outcome": r.summary["outcome"], "real_time_factor": r.summary["real_time_factor"],
                         "com_displacement_m": float(np.hypot(*(com[-1, :2] - com[0, :2]))),
                         "com_dx_m": float(com[-1, 0] - com[0, 0]), "max_sinkage_m": rep["max_sinkage_m"],
                         "rut": rep["rut"]})
    return rows


# -- 7. held still on a slope ------------------------------------------------------------------------------
#: part 7's steps: the scene's (a 20 ms base step under the embedded estimate's control, loose tolerances), and
#: fixed 20 ms and 10 ms steps (J at every step)
FIXED = ["sim.integrator.params.step_control=fixed", "sim.integrator.params.jacobian_every=1"]
HOLD_STEPS = {"scene's": ([], {}), "fixed 20 ms": (FIXED, {}), "fixed 10 ms": (FIXED, {"dt": 0.01})}


def hold(quick: bool) -> list[dict]:
    """EELS 1.0, screws idle, on the snow field laid on a 5° plane: the creep after settling against the
    shear's regularisation v_ε and the step (HOLD_STEPS); the creep's bound is v_ε
    (tests/terramechanics/test_hold_on_slope.py)."""
    duration = 6.0 if quick else 12.0
    text = (ROOT / "terrains" / "snow-field.yaml").read_text()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "snow-slope.yaml"
        path.write_text(text.replace("base_height: 0.0", "base: {kind: plane, tilt: 0.0873, azimuth: 1.5708}"))
        for v_eps in (0.01, 0.001):
            for step, (overrides, sim) in HOLD_STEPS.items():
                s = load_session("snow-screw-traverse", overrides=[
                    f"settle={duration}", f"terrain={path}", f"components.contact.params.v_eps={v_eps}", *overrides],
                    sim_overrides={"duration": duration, **sim})
                t0 = time.perf_counter()
                r = s.run()
                wall = time.perf_counter() - t0
                t, pose = r["t"], r["tail_pose.pose"]
                i = int(np.searchsorted(t, 2.0))
                rows.append({"v_eps_m_s": v_eps, "step": step, "outcome": r.summary["outcome"],
                             "creep_mm_s": float(np.linalg.norm(pose[-1, :2] - pose[i, :2]) / (t[-1] - t[i]) * 1e3),
                             "real_time_factor": duration / wall})
    return rows


# -- 8. the step on snow -------------------------------------------------------------------------------------
_I = "sim.integrator.params."
#: part 8's integrator settings (overrides, sim overrides) against fixed 2 ms steps (1 cm from 1 ms over 45 s)
STEPS = {
    "the scene's: error control, 1 cm / 0.1 m/s / 10 %, J 4th": ([], {}),
    "fixed 20 ms, J every 8th": ([f"{_I}step_control=fixed", f"{_I}jacobian_every=8"], {}),
    "fixed 20 ms, J every step": ([f"{_I}step_control=fixed", f"{_I}jacobian_every=1"], {}),
    "fixed 10 ms": ([f"{_I}step_control=fixed", f"{_I}jacobian_every=1"], {"dt": 0.01}),
    "fixed 5 ms": ([f"{_I}step_control=fixed", f"{_I}jacobian_every=1"], {"dt": 0.005}),
    "error control, 3 mm / 0.03 m/s / 3 %": ([f"{_I}atol_q=3e-3", f"{_I}atol_v=3e-2", f"{_I}rtol=3e-2"], {}),
}
REFERENCE_STEP = ([f"{_I}step_control=fixed", f"{_I}jacobian_every=1"], {"dt": 0.002})


def _tail_track(overrides, sim, duration: float, rate: float | None = None):
    """snow-screw-traverse's tail (x, y) every 0.1 s, the real-time factor and the outcome."""
    extra = [f"screw_speed={rate}"] if rate is not None else []
    s = load_session("snow-screw-traverse", overrides=[*overrides, *extra], sim_overrides={"duration": duration, **sim})
    t0 = time.perf_counter()
    r = s.run()
    wall = time.perf_counter() - t0
    grid = np.arange(0.0, duration + 1e-9, 0.1)
    t, p = r["t"], r["tail_pose.pose"]
    track = np.column_stack([np.interp(grid, t, p[:, k]) for k in range(2)])
    return track, duration / wall, r.summary["outcome"]


def step_on_snow(quick: bool) -> list[dict]:
    """Each of STEPS against fixed 2 ms: the tail's distance from it at 5 s, 9 s (the forward phase's end) and
    at most over the run (45 s; --quick: 9 s), and the forward phase's speed at 1 rad/s (settle 1 s, the
    late half of 4 s driving), where a stale Jacobian once ran it backwards."""
    duration = 9.0 if quick else 45.0
    ref, ref_rtf, _ = _tail_track(*REFERENCE_STEP, duration)
    slow_ref = _tail_track(*REFERENCE_STEP, 5.0, rate=1.0)[0]
    late = slice(30, 51)                       # 3 to 5 s: the late half of the forward phase

    def speed(track):
        return float(np.polyfit(np.arange(30, 51) * 0.1, track[late, 0], 1)[0])

    rows = [{"step": "fixed 2 ms (reference)", "real_time_factor": ref_rtf, "off_5s_m": 0.0, "off_9s_m": 0.0,
             "off_max_m": 0.0, "speed_1rad_s": speed(slow_ref), "outcome": "success"}]
    for name, (overrides, sim) in STEPS.items():
        track, rtf, outcome = _tail_track(overrides, sim, duration)
        off = np.linalg.norm(track - ref, axis=1)
        slow = _tail_track(overrides, sim, 5.0, rate=1.0)[0]
        rows.append({"step": name, "real_time_factor": rtf, "off_5s_m": float(off[50]), "off_9s_m": float(off[90]),
                     "off_max_m": float(off.max()), "speed_1rad_s": speed(slow), "outcome": outcome})
    return rows


# -- report -------------------------------------------------------------------------------------------------
def table(out: dict) -> str:
    d = out["drawbar"]
    lines = [f"1. drawbar pull, one module ({', '.join(d['screws'])}), weight {d['module_weight_N']:.1f} N, "
             f"sinkage {100 * d['sinkage_m']:.2f} cm, {d['omega_rad_s']:g} rad/s",
             "   slip    thrust N    drawbar/weight"]
    lines += [f"   {s:5.2f}  {T:9.2f}    {T / d['module_weight_N']:6.3f}" for s, T in zip(d["slip"], d["thrust_N"])]
    lines += ["   towing N   steady slip   snow-drawbar-pull: slip   travel mm/s   RTF   outcome"]
    dash = lambda v, fmt: "—".rjust(len(format(0.0, fmt))) if v is None else format(v, fmt)   # noqa: E731
    lines += [f"   {F:8.2f}   {dash(s, '11.3f')}   {dash(y['slip'], '23.3f')}   {1e3 * y['travel_speed_m_s']:11.1f}  "
              f"{y['real_time_factor']:5.1f}  {y['outcome']}"
              for F, s, y in zip(d["towing_force_N"], d["steady_slip"], d["dynamic"])]
    lines += ["   snow-drawbar-pull driven: slip set   slip   drawbar N   RTF   outcome"]
    lines += [f"   {y['slip_set']:+29.2f}  {y['slip']:6.3f}  {y['drawbar_pull_N']:9.2f}  {y['real_time_factor']:5.1f}  "
              f"{y['outcome']}" for y in d["driven"]]
    lines += ["2. speed along the chord against screw rate", "   scene                    rad/s   m/s      RTF   outcome"]
    lines += [f"   {r['scene']:24s} {r['screw_rate_rad_s']:5.1f}  {r['speed_m_s']:7.4f}  {r['real_time_factor']:6.1f}  "
              f"{r['outcome']}" for r in out["speed"]]
    lines += ["3. cost against the snow grid's cell (snow-screw-traverse, its own settings)",
              "   cell m   base              steps   µs/step   RTF    outcome"]
    lines += [f"   {r['cell_m']:6.3f}  {r['base']:17s} {r['steps']:6d}  {r['us_per_step']:8.0f}  "
              f"{r['real_time_factor']:5.1f}  {r['outcome']}" for r in out["cost"]]
    lines += ["4. the schedule on snow and on hard ice", "   scene                    s     made good m   path m   RTF   outcome"]
    lines += [f"   {r['scene']:24s} {r['duration_s']:4.0f}  {r['distance_made_good_m']:10.3f}  {r['path_length_m']:7.3f}  "
              f"{r['real_time_factor']:5.1f}  {r['outcome']}" for r in out["traverse"]]
    for r in out["traverse"]:
        if "rut" in r:
            u = r["rut"]
            lines.append(f"   rut: {u['deformed_nodes']} nodes, deepest {100 * u['max_rut_depth_m']:.1f} cm, "
                         f"{1e3 * u['rut_volume_m3']:.1f} L; mean screw sinkage {100 * r['mean_sinkage_m']:.1f} cm; "
                         f"saved {r['terrain_npz']}, {r['rut_png']}")
    wl = out["wheel"]
    lines += [f"5. rigid wheel r {wl['radius_m']} m, b {wl['width_m']} m, {wl['load_N']:.0f} N on dry sand "
              f"(cell {wl['cell_m']} m)", "   slip   sinkage cm   drawbar N   DP/W    torque N·m"]
    lines += [f"   {r['slip']:4.2f}  {100 * r['sinkage_m']:9.2f}  {r['drawbar_pull_N']:10.1f}  "
              f"{r['drawbar_pull_N'] / wl['load_N']:6.3f}  {r['torque_Nm']:9.1f}" for r in wl["rows"]]
    lines += ["6. shape gaits on soil (lateral resistance: the scene's skin, Mohr–Coulomb alone, the rut walls)",
              "   scene                    lateral     s     CoM moved m   dx m     max sink cm   rut nodes   RTF   outcome"]
    lines += [f"   {r['scene']:24s} {r['lateral']:10s} {r['duration_s']:4.0f}  {r['com_displacement_m']:10.3f}  "
              f"{r['com_dx_m']:+7.3f}  {100 * r['max_sinkage_m']:11.2f}  {r['rut']['deformed_nodes']:9d}  "
              f"{r['real_time_factor']:5.1f}  {r['outcome']}" for r in out["shape_gaits"]]
    lines += ["7. held still on a 5° snow slope, screws idle (the creep's bound: v_eps)",
              "   v_eps m/s   step             creep mm/s   RTF   outcome"]
    lines += [f"   {r['v_eps_m_s']:8.3f}   {r['step']:<14}   {r['creep_mm_s']:10.3f}  "
              f"{r['real_time_factor']:5.1f}  {r['outcome']}" for r in out["hold"]]
    lines += ["8. the step on snow (snow-screw-traverse's tail against fixed 2 ms; forward speed at 1 rad/s)",
              "   step                                                        RTF   off 5 s  off 9 s   max cm  "
              "m/s at 1 rad/s  outcome"]
    lines += [f"   {r['step']:58s} {r['real_time_factor']:5.1f}  {100 * r['off_5s_m']:6.1f}  "
              f"{100 * r['off_9s_m']:7.1f}  {100 * r['off_max_m']:7.1f}  {r['speed_1rad_s']:14.4f}  {r['outcome']}"
              for r in out["step"]]
    return "\n".join(lines)


def plot(out: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 4, figsize=(19, 4))
    d = out["drawbar"]
    ax[0].plot(d["slip"], np.array(d["thrust_N"]) / d["module_weight_N"], marker="o")
    ok = [(s, F) for s, F in zip(d["steady_slip"], d["towing_force_N"]) if s is not None]
    if ok:
        ax[0].plot([s for s, _ in ok], [F / d["module_weight_N"] for _, F in ok], "x", label="steady slip under tow")
    dyn = [(y["slip"], y["tow_N"]) for y in d.get("dynamic", []) if y["slip"] is not None]
    if dyn:
        ax[0].plot([s for s, _ in dyn], [F / d["module_weight_N"] for _, F in dyn], "s", mfc="none",
                   label="towed on the carriage (snow-drawbar-pull)")
    ax[0].plot([y["slip"] for y in d.get("driven", [])], [y["drawbar_pull_N"] / d["module_weight_N"]
                                                         for y in d.get("driven", [])], "^", mfc="none",
               label="driven at a set slip (snow-drawbar-pull)")
    ax[0].set_xlabel("slip")
    ax[0].set_ylabel("drawbar pull / weight")
    ax[0].set_title("one EELS 1.0 module on snow")
    ax[0].axhline(0.0, color="k", lw=0.5)
    ax[0].legend()
    for scene, label in (("snow-screw-traverse", "snow"), ("surface-screw-traverse", "hard ice")):
        rows = [r for r in out["speed"] if r["scene"] == scene]
        ax[1].plot([r["screw_rate_rad_s"] for r in rows], [r["speed_m_s"] for r in rows], marker="o", label=label)
    ax[1].set_xlabel("screw rate (rad/s)")
    ax[1].set_ylabel("tail speed along the chord (m/s)")
    ax[1].set_title("EELS 1.0, forward phase")
    ax[1].legend()
    c = [r for r in out["cost"] if r["base"] == "plane"]
    ax[2].loglog([r["cell_m"] for r in c], [r["us_per_step"] for r in c], marker="o", label="plane base")
    for base, marker in (("dem", "s"), ("plane, bulldozing", "^")):
        d = [r for r in out["cost"] if r["base"] == base]
        ax[2].loglog([r["cell_m"] for r in d], [r["us_per_step"] for r in d], marker=marker, ls="", label=base)
    ax[2].legend()
    ax[2].set_xlabel("snow grid cell (m)")
    ax[2].set_ylabel("wall µs per 20 ms step")
    ax[2].set_title("cost per step")
    # part 8: what each step buys, accuracy (the tail at the forward phase's end and at most, against 2 ms)
    # against speed; the scene's setting marked
    for r in out.get("step", [])[1:]:
        scene = r["step"].startswith("the scene's")
        ax[3].plot(r["real_time_factor"], 100 * r["off_9s_m"], "o", color="C3" if scene else "C0")
        ax[3].plot(r["real_time_factor"], 100 * r["off_max_m"], "^", color="C3" if scene else "C0", alpha=0.5)
        ax[3].annotate(r["step"].split(":")[0].replace(", J every", ", J/"), (r["real_time_factor"], 100 * r["off_9s_m"]),
                       fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax[3].set_yscale("symlog", linthresh=0.1)
    ax[3].set_xlabel("real-time factor")
    ax[3].set_ylabel("tail off fixed 2 ms (cm): ● at 9 s, ▲ at most in 45 s")
    ax[3].set_title("the step on snow (the scene's in red)")
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer points, shorter runs (under a minute)")
    ap.add_argument("--json", type=Path, default=RESULTS / "soft_terrain.json")
    ap.add_argument("--png", type=Path, default=RESULTS / "soft_terrain.png")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    a.json.parent.mkdir(parents=True, exist_ok=True)
    out = {"quick": a.quick, "drawbar": drawbar(a.quick), "speed": speeds(a.quick), "cost": cost(a.quick),
           "traverse": traverse(a.quick, a.json), "wheel": wheel(a.quick), "shape_gaits": shape_gaits(a.quick),
           "hold": hold(a.quick), "step": step_on_snow(a.quick)}
    out["bench_wall_s"] = time.perf_counter() - t0
    print(table(out))
    print(f"bench wall time {out['bench_wall_s']:.1f} s")
    a.json.write_text(json.dumps(out, indent=2) + "\n")
    plot(out, a.png)
    print(f"wrote {a.json}, {a.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
