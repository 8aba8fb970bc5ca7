"""Extremes: where each integrator stops being stable, and what the framework does then.

    .venv/bin/python bench/extremes.py [--quick] [--json FILE]

Scene: the default traverse (surface-screw-traverse, all screws forward from 0.1 s), short
horizon. For every integrator and contact stiffness k (1e3 .. 1e8 N/m, the `material.k`
override of the contact) the base step is doubled from 0.125 ms until the run fails; the
table gives the largest step that ran clean. A failure is what the framework reports — a
non-finite-state stop naming the component, or the integrator giving up — or the robot
leaving the physical range (its CoM sinking below the ice or flying off: `unphysical`),
never a silent NaN: every row states how the first failing step ended. The robot starts
touching the ice without overlap, so a stiff contact is not kicked by its initial state. A
joint turning faster than JOINT_RATE_BOUND (ten times the fastest URDF rate limit) stops the
run as unphysical too (a stop condition added to the scene), and so does a joint controller
that does not hold its setpoint once settled (TRACK_POS): a loop too stiff for the step can
chatter between its torque limits and freeze the joint, every state finite.
Also: a 100-module robot (rk4 and semi-implicit Euler at 0.5 ms).

Near-massless links (issue 6; issue 3's claim that without joint armature a light tail cap makes
explicit integration blow up at 1 ms): EELS 1.0 with 4 modules, the mass and inertia tensor of
chosen links multiplied by s (1e-2 .. 1e-6) in the URDF text, which then runs as a user URDF of
the design (`robot.urdf`, same scene, contact k = 1e5 N/m). Link sets: the tail cap (`tail`,
the free-flyer root), every knuckle (`knuckle_*`, between each bend and twist joint) and every
screw pair (`screw_*_link_*`). Each runs with the default joint armature (per-effort rule,
floor 1e-3 kg·m²) and with none (`armature_floor=0`, `armature_per_effort` all 0). What sets the
stable step is not the lightest link but the smallest *apparent* inertia of a joint,
1/(M⁻¹)ᵢᵢ: the inertia a joint torque meets when every other DOF is free (the tail's side of
bend_00, the tail + knuckle_00 side of twist_00, a screw pair's spin). A knuckle lies between
two joints whose other sides are heavy, so no joint sees it alone; the table lists that smallest
apparent inertia (armature included) and its joint, and the RK4 step bound predicted from
it: the largest h with |R(hλ)| <= 1 for every pole λ of every joint's PID loop (built-in gains)
closed on that joint's apparent inertia (a bend loop's fast pair is ω ≈ √(kd/(I·tf)), a screw
loop's pole −kp/I). The step search here also halves below 0.125 ms (to 15.6 µs, --quick, or
7.8 µs; rosenbrock2 stays at >= 1 ms), over LIGHT_HORIZON s; --quick runs semi-implicit Euler,
RK4 and rosenbrock2, the full run adds dopri5, capped at LIGHT_DOPRI5_SUBSTEPS sub-steps per
base step: an adaptive run that needs more is reported as the integrator giving up rather than
crawling at micro-steps.
"""

from __future__ import annotations

import json
import sys
import tempfile
import xml.etree.ElementTree as ET
from fnmatch import fnmatch
from pathlib import Path

import click
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "validation"))
from validation_scenes import run, session  # noqa: E402

from snakesim.components.control.pid import DEFAULT_GAINS  # noqa: E402
from snakesim.components.multibody.robot_model import joint_kind  # noqa: E402
from snakesim.framework.assembly import StopSpec  # noqa: E402

INTEGRATORS = {"semi_implicit_euler": {}, "rk4": {}, "dopri5": {"rtol": 1e-4, "atol": 1e-6},
               "rosenbrock2": {"jacobian_every": 5}}


def _max_rate_limit() -> float:
    """The fastest <limit velocity> of the design's joints, rad/s (the screws' 10 rad/s on EELS 1.0)."""
    from snakesim.robots import load_robot

    root = ET.fromstring(load_robot("eels-1.0", modules=1).urdf)
    return max(float(lim.get("velocity", 0.0)) for lim in root.iter("limit"))


#: rad/s. A joint turning ten times faster than the fastest rated joint has left the physical range:
#: a screw whose spin inertia is too small for the step rings at 1e5 rad/s under a saturated PID
#: while the CoM stays put (friction bounds the force), which only this check catches.
JOINT_RATE_BOUND = 10.0 * _max_rate_limit()


#: the joint PIDs must hold their setpoints once settled: position error below TRACK_POS rad,
#: screw rate error below TRACK_RATE rad/s, read at the last sample whose setpoint has stood for
#: TRACK_SETTLE s. A settled loop errs by load/kp, about 0.03 here (0.1 at the coarse clean steps);
#: a loop too stiff for the step instead chatters between torque limits, and with RK4 the
#: chatter cancels over the stages: the joint freezes where it is, errors of 0.4 rad or 5-60
#: rad/s, with every state finite and the CoM in range.
TRACK_POS, TRACK_RATE, TRACK_SETTLE = 0.1, 1.0, 0.05


def _patch(res):
    """Record every step, and the PID errors; stop (reported, with its time) once a joint rate
    leaves the physical range."""
    res.sim.record_rate = None
    # the tail pose samples at the scene's record rate (50 Hz): at every step here instead, so
    # coarse steps (8 ms) are tried rather than refused as rates that do not divide the step
    if "tail_pose" in res.components:
        res.components["tail_pose"] = res.components["tail_pose"].model_copy(update={"rate": None})
    res.record.append(("pid.error", None))
    res.stop.append((StopSpec(signal="robot.joint_v", abs_above=JOINT_RATE_BOUND,
                              reason=f"joint rate above {JOINT_RATE_BOUND:g} rad/s (unphysical)"), None))


def tracking_failure(s, r) -> str | None:
    """Why the joint controllers do not hold their setpoints at the end (see TRACK_POS), or None."""
    pid = s.plan.components["pid"]
    if pid.p.gains or pid.p.kind_gains:
        raise ValueError("tracking check assumes the PID's built-in gains (screws velocity, others position)")
    joints = s.plan.components["robot"].robot.joints      # the PID's order too: one robot source
    velocity = np.array([DEFAULT_GAINS[joint_kind(j)]["mode"] == "velocity" for j in joints])
    t, sp, err = np.asarray(r["t"]), np.asarray(r["phases.setpoint"]), np.abs(np.asarray(r["pid.error"]))
    new = np.r_[True, np.any(sp[1:] != sp[:-1], axis=1)]               # a setpoint first seen here
    since = t - t[np.maximum.accumulate(np.where(new, np.arange(t.size), 0))]
    settled = np.flatnonzero(since >= TRACK_SETTLE - 1e-12)
    if not settled.size:
        return None
    e = err[settled[-1]]
    bad = np.flatnonzero(np.where(velocity, e > TRACK_RATE, e > TRACK_POS))
    if not bad.size:
        return None
    j = bad[np.argmax(e[bad] / np.where(velocity[bad], TRACK_RATE, TRACK_POS))]
    unit = "rad/s" if velocity[j] else "rad"
    return (f"unphysical: {joints[j]} off its setpoint by {e[j]:.3g} {unit} at t = {t[settled[-1]]:.3g} s "
            f"(a loop the step does not resolve)")


def attempt(k, integ, dt, horizon, modules, extra=(), integ_params=None):
    sets = ["settle=0.1", f"phase={horizon}", f"robot.modules={modules}",
            f"components.contact.params.material.k={k}",
            "components.robot.params.base_position=[0.0, 0.0, 0.09]", *extra]   # touching, no initial overlap
    sim = {"duration": horizon, "dt": dt, "integrator": {"name": integ, "params": integ_params or INTEGRATORS[integ]}}
    try:
        s, r = run("surface-screw-traverse", sets, sim, patch=_patch)
    except Exception as e:
        return {"ok": False, "how": f"build: {type(e).__name__}: {str(e)[:80]}"}
    sm = r.summary
    z = np.asarray(r["robot.com"])[:, 2]
    if r.last_good_state is not None or not sm["completed"]:
        return {"ok": False, "how": sm["stop_reason"][:90], "rtf": sm["real_time_factor"]}
    # the robot lies on the ice: its CoM may sink by the contact deflection, never below the
    # ice, and must not be thrown off it (a contact blow-up that stayed finite)
    if not (np.isfinite(z).all() and z.min() > 0.0 and z.max() < z[0] + 0.05):
        return {"ok": False, "how": f"unphysical: CoM z in [{z.min():.3g}, {z.max():.3g}] m", "rtf": sm["real_time_factor"]}
    why = tracking_failure(s, r)
    if why:
        return {"ok": False, "how": why, "rtf": sm["real_time_factor"]}
    return {"ok": True, "how": "ok", "rtf": sm["real_time_factor"]}


# -- step search -------------------------------------------------------------------------------
def largest_clean_step(try_step, dts, start=0):
    """Double the step from dts[start] while runs are clean; if the first fails, halve down to dts[0].

    try_step(dt) -> attempt dict. Returns (best (dt, attempt) or None, first failure (dt, attempt)
    or None): the largest clean step and the step just above it that failed."""
    best = fail = None
    for i in range(start, len(dts)):
        a = try_step(dts[i])
        if not a["ok"]:
            fail = (dts[i], a)
            break
        best = (dts[i], a)
    if best is None and fail is not None:          # failed at the start: look below it
        for i in range(start - 1, -1, -1):
            a = try_step(dts[i])
            if a["ok"]:
                best = (dts[i], a)
                break
            fail = (dts[i], a)
    return best, fail


def search_row(best, fail) -> dict:
    return {"max_clean_dt": best[0] if best else None, "rtf": best[1]["rtf"] if best else None,
            "first_fail_dt": fail[0] if fail else None,
            "how": fail[1]["how"] if fail else "none up to the largest step"}


def fmt(v, spec):
    return "—" if v is None else format(v, spec)


# -- near-massless links ------------------------------------------------------------------------
LIGHT_MODULES = 4
LIGHT_K = 1e5
LIGHT_HORIZON = 0.512       # s, whole steps for every dt tried
LIGHT_SETS = {"tail cap": "tail", "knuckles": "knuckle_*", "screws": "screw_*_link_*"}
LIGHT_DOPRI5_SUBSTEPS = 64
NO_ARMATURE = ["components.robot.params.armature_floor=0",
               "components.robot.params.armature_per_effort={bend: 0, twist: 0, screw: 0, other: 0}"]


def light_urdf(text: str, pattern: str, scale: float) -> tuple[str, list[str]]:
    """The URDF with mass and inertia tensor of every link matching ``pattern`` times ``scale``
    (centre of mass unchanged, so the scaled link keeps its shape: I/m is the same)."""
    root = ET.fromstring(text)
    hit = []
    for link in root.findall("link"):
        inertial = link.find("inertial")
        if inertial is None or not fnmatch(link.get("name"), pattern):
            continue
        mass, inertia = inertial.find("mass"), inertial.find("inertia")
        mass.set("value", repr(float(mass.get("value")) * scale))
        for key, value in inertia.attrib.items():
            inertia.set(key, repr(float(value) * scale))
        hit.append(link.get("name"))
    if not hit:
        raise ValueError(f"light links: pattern '{pattern}' matches no link with an <inertial>")
    return ET.tostring(root, encoding="unicode"), hit


def apparent_inertias(sets) -> tuple[np.ndarray, list[str], float]:
    """(1/(M⁻¹)ᵢᵢ of every DOF joint, kg·m², the joint names, the armature summed over the joints)
    at the start state of the scene with ``sets``: the inertia a joint torque meets with every
    other DOF free, armature included."""
    import pinocchio as pin

    robot = session("surface-screw-traverse", sets, {"duration": 1e-3, "dt": 1e-3}).plan.components["robot"]
    model, data = robot.dyn.model, robot.dyn.data
    m = pin.crba(model, data, robot._x0[:model.nq])       # upper triangle, armature on the diagonal
    m = np.triu(m) + np.triu(m, 1).T
    dof = np.array([model.joints[model.getJointId(j)].idx_v for j in robot.robot.joints])
    apparent = 1.0 / np.diag(np.linalg.inv(m))[dof]
    return apparent, list(robot.robot.joints), float(sum(robot.armature_user.values()))


def loop_poles(kind: str, inertia: float) -> np.ndarray:
    """Poles, 1/s, of one joint's PID (built-in gains of its kind, pid.py) closed on the apparent
    inertia, linearised and unsaturated. Position: states [q, v, z, ∫e] with τ = kp·e + ki·∫e +
    kd·z, e = −q, ż = (−v − z)/tf. Velocity: [v, ∫e] with τ = kp·e + ki·∫e, e = −v (kd = 0 here)."""
    g = DEFAULT_GAINS[kind]
    kp, ki, kd, tf, i_ = g["kp"], g["ki"], g["kd"], g["tf"], inertia
    if g["mode"] == "velocity":
        return np.linalg.eigvals(np.array([[-kp / i_, ki / i_], [-1.0, 0.0]]))
    if tf <= 0:                                   # unfiltered: τ = −kp q − kd v + ki ∫e
        return np.linalg.eigvals(np.array([[0, 1, 0], [-kp / i_, -kd / i_, ki / i_], [-1, 0, 0]]))
    return np.linalg.eigvals(np.array([[0, 1, 0, 0], [-kp / i_, 0, kd / i_, ki / i_],
                                       [0, -1 / tf, -1 / tf, 0], [-1, 0, 0, 0]], dtype=float))


def rk4_step_bound(poles: np.ndarray) -> float:
    """The largest h with |R(hλ)| <= 1 for every pole λ, R(z) = 1 + z + z²/2 + z³/6 + z⁴/24 the
    RK4 stability function (bisection along each pole's ray; inf when every pole is 0)."""
    def stable(z):
        return abs(1 + z + z * z / 2 + z ** 3 / 6 + z ** 4 / 24) <= 1 + 1e-9
    bound = np.inf
    for lam in poles[np.abs(poles) > 0]:
        lo, hi = 0.0, 4.0 / abs(lam)               # |hλ| > 2.83 leaves the region on every ray
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if stable(mid * lam) else (lo, mid)
        bound = min(bound, lo)
    return bound


def light_links(quick: bool, workdir: Path, horizon: float = LIGHT_HORIZON) -> list[dict]:
    from snakesim.robots import load_robot

    scales = [1.0, 1e-2, 1e-4, 1e-6] if quick else [1.0, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6]
    integs = ["semi_implicit_euler", "rk4", "rosenbrock2"] if quick else list(INTEGRATORS)
    halvings = 3 if quick else 4
    dts = [1.25e-4 * 2 ** i for i in range(-halvings, 6)]    # to 4 ms: tail_pose samples at 50 Hz
    base = load_robot("eels-1.0", modules=LIGHT_MODULES).urdf
    rows = []
    print(f"\nnear-massless links: EELS 1.0, {LIGHT_MODULES} modules, k = {LIGHT_K:.0e} N/m, {horizon:g} s; "
          "mass and inertia of the links times s\n")
    print("| links | s | armature | smallest apparent inertia kg·m² (joint) | rk4 bound of the PID loops s "
          "| integrator | largest clean dt s | RTF there | first failing dt s | how it failed |\n"
          "|---|---:|---|---|---:|---|---:|---:|---:|---|")
    cases = [("none", 1.0)] + [(name, s) for name in LIGHT_SETS for s in scales if s != 1.0]
    for n, (name, scale) in enumerate(cases):
        if name == "none":
            path = None
        else:
            text, _ = light_urdf(base, LIGHT_SETS[name], scale)
            path = workdir / f"light-{n}.urdf"
            path.write_text(text, encoding="utf-8")
        for armature in ("default", "zero"):
            extra = ([f"robot.modules={LIGHT_MODULES}"] + ([f"robot.urdf={path}"] if path else [])
                     + (NO_ARMATURE if armature == "zero" else []))
            apparent, joints, arm_sum = apparent_inertias(extra)
            if (arm_sum == 0.0) != (armature == "zero"):
                raise AssertionError(f"armature override not applied: total {arm_sum} kg·m²")
            i_min, joint = float(apparent.min()), joints[int(np.argmin(apparent))]
            h_rk4 = min(rk4_step_bound(loop_poles(joint_kind(j), a)) for j, a in zip(joints, apparent))
            for integ in integs:
                params = dict(INTEGRATORS[integ])
                if integ == "dopri5":
                    params["max_substeps"] = LIGHT_DOPRI5_SUBSTEPS
                start = dts.index(1e-3) if integ == "rosenbrock2" else halvings
                floor = start if integ == "rosenbrock2" else 0       # FD Jacobian: too costly below 1 ms
                best, fail = largest_clean_step(
                    lambda dt: attempt(LIGHT_K, integ, dt, horizon, LIGHT_MODULES, extra, params),  # noqa: B023
                    dts[floor:], start - floor)
                row = {"case": "light links", "links": name, "scale": scale, "armature": armature,
                       "apparent_inertia_min": i_min, "apparent_inertia_joint": joint,
                       "rk4_bound_pid_loops": h_rk4, "integrator": integ,
                       "k": LIGHT_K, "horizon": horizon, "smallest_dt_tried": dts[floor], **search_row(best, fail)}
                rows.append(row)
                print(f"| {name} | {scale:.0e} | {armature} | {i_min:.3g} ({joint}) | {h_rk4:.3g} | {integ} | "
                      f"{fmt(row['max_clean_dt'], 'g') if best else '< ' + format(dts[floor], 'g')} | "
                      f"{fmt(row['rtf'], '.3g')} | {fmt(row['first_fail_dt'], 'g')} | {row['how']} |", flush=True)
    return rows


@click.command()
@click.option("--quick", is_flag=True)
@click.option("--json", "json_path", type=click.Path(dir_okay=False))
@click.option("--only-light", is_flag=True, help="only the near-massless-links table")
def main(quick, json_path, only_light):
    horizon, modules = (0.512, 4) if quick else (1.024, 10)   # whole steps for every dt tried
    ks = [1e3, 1e5, 1e7] if quick else [1e3, 1e4, 1e5, 1e6, 1e7, 1e8]
    dts = [1.25e-4 * 2 ** i for i in range(8 if quick else 9)]
    rows = []
    if not only_light:
        print(f"stable step per integrator and contact stiffness ({modules} modules, {horizon:g} s)\n")
        print("| integrator | k N/m | largest clean dt s | RTF there | first failing dt s | how it failed |\n"
              "|---|---:|---:|---:|---:|---|")
    for integ in INTEGRATORS if not only_light else ():
        for k in ks:
            start = dts.index(1e-3) if integ == "rosenbrock2" else 0    # FD Jacobian: too costly at small steps
            best, fail = largest_clean_step(lambda dt: attempt(k, integ, dt, horizon, modules),  # noqa: B023
                                            dts[start:])
            row = {"integrator": integ, "k": k, **search_row(best, fail)}
            rows.append(row)
            print(f"| {integ} | {k:.0e} | {fmt(row['max_clean_dt'], 'g')} | {fmt(row['rtf'], '.3g')} | "
                  f"{fmt(row['first_fail_dt'], 'g')} | {row['how']} |", flush=True)
    if not only_light:
        print("\n100-module EELS 1.0 (rk4 and semi_implicit_euler, dt = 0.5 ms, 0.1 s):")
    for integ in ("semi_implicit_euler", "rk4") if not only_light else ():
        a = attempt(1e5, integ, 5e-4, 0.1, 100, ["crescent_bend=0.03"])
        rows.append({"case": "100 modules", "integrator": integ, **a})
        print(f"  {integ}: {a['how']}, RTF {a.get('rtf', float('nan')):.3g}")
    with tempfile.TemporaryDirectory() as tmp:
        rows += light_links(quick, Path(tmp))
    if json_path:
        Path(json_path).parent.mkdir(parents=True, exist_ok=True)
        Path(json_path).write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
