"""Held robots: how fast each integrator setting lets a robot creep that should (nearly) hold still.

Three cases, each against a converged reference computed in the same run:

  slope      eels-1.0, 2 modules, on a 4° slope (μ 0.1, thread anisotropy ‖e_v‖ 4), screws held by
             screw_drive (velocity servo at 0), joints by its PD lock: creep = downhill speed of the
             centre of mass over the second half of 2 s. Reference: RK4 at 0.1 ms.
  stop       the default scene (surface-screw-traverse) with its schedule compressed (settle 0.5 s,
             phases 1.5 s: stopped from 8 s) run to 10 s: creep = tail speed over [8.5, 10] s.
             Reference: RK4 at 0.25 ms (the validation reference setting).
  walls      placement-walls-hold (EELS 1.5 pre-loaded between walls, μ 1.35, v_ε 0.2 mm/s), from a
             placement-walls run's state: creep = sinking speed of the centre of mass over the last
             3 s of 10 s. Reference: rosenbrock_w (ros2) at 1 ms, and the regularised law
             v_ε r/sqrt(1 − r²), r = m g/(μ ΣF_n) (tests/placement/test_placement_hold.py).

    .venv/bin/python bench/held_cases.py [--quick] [--case NAME] [--match TEXT] [--json FILE]
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "validation"))
from screw_scenes import downhill, held_on_slope  # noqa: E402
from validation_scenes import run  # noqa: E402

from snakesim.framework.session import load_session  # noqa: E402

G = 9.81


def _integrator(spec: dict) -> dict:
    return {"name": spec["name"], "params": spec.get("params", {})}


def slope_case(spec: dict, dt: float, tmp: Path) -> dict:
    theta = math.radians(4.0)
    r = held_on_slope(theta=theta, mu=0.1, ev_a=4.0, duration=2.0, dt=dt, integrator=_integrator(spec),
                      record_rate=50).run()
    t, down = np.asarray(r["t"]), downhill(r["robot.com"], theta)
    late = t >= 1.0
    return {"creep_m_s": float(np.polyfit(t[late], down[late], 1)[0]), "rtf": r.summary["real_time_factor"],
            "completed": r.summary["completed"]}


def stop_case(spec: dict, dt: float, tmp: Path) -> dict:
    _, r = run("surface-screw-traverse", ["settle=0.5", "phase=1.5"],
               {"duration": 10.0, "dt": dt, "integrator": _integrator(spec)})
    t, pose = np.asarray(r["t"]), np.asarray(r["tail_pose.pose"])
    late = t >= 8.5
    vx, vy = (np.polyfit(t[late], pose[late, j], 1)[0] for j in (0, 1))
    return {"creep_m_s": float(math.hypot(vx, vy)), "rtf": r.summary["real_time_factor"],
            "completed": r.summary["completed"]}


_HELD = {}


def walls_case(spec: dict, dt: float, tmp: Path) -> dict:
    from snakesim.components.placement.handoff import held_state, hold_overrides
    if "state" not in _HELD:
        s = load_session("placement-walls", sim_overrides={"duration": 2.2})
        _HELD["state"] = held_state(s, s.run())
    s = load_session("placement-walls-hold", overrides=hold_overrides(_HELD["state"]) + ["friction=1.35", "v_eps=2e-4"],
                     sim_overrides={"duration": 10.0, "dt": dt, "integrator": _integrator(spec)})
    r = s.run()
    H = "placement-hold/"
    t, z = np.asarray(r["t"]), np.asarray(r[H + "robot.com"])[:, 2]
    late = t >= t[-1] - 3.0
    mg = sum(ln.mass for ln in s.plan.components[H + "robot"].robot.tree.links) * G
    rr = mg / (1.35 * np.asarray(r[H + "contact.screw_normal_force"])[late].sum(axis=1).mean())
    law = 2e-4 * rr / math.sqrt(1 - rr * rr) if rr < 1 else float("inf")
    return {"creep_m_s": float(-np.polyfit(t[late], z[late], 1)[0]), "rtf": r.summary["real_time_factor"],
            "completed": r.summary["completed"], "law_m_s": law}


CASES = {"slope": (slope_case, ({"name": "rk4"}, 1e-4)),
         "stop": (stop_case, ({"name": "rk4"}, 2.5e-4)),
         "walls": (walls_case, ({"name": "rosenbrock_w", "params": {"method": "ros2"}}, 1e-3))}


def settings(quick: bool, case: str):
    # fixed steps unless a setting names error control (rosenbrock_w's default since issue 24, which refuses
    # refresh_substeps; the stop case's scene params merge under these)
    W = lambda m, dt, **p: ({"name": "rosenbrock_w",  # noqa: E731
                             "params": {"method": m, "step_control": "fixed", **p}}, dt)
    out = [W("ros2", 1e-2), W("ros2", 5e-3), W("ros2", 5e-3, jacobian_every=5), W("ros34pw2", 1e-2),
           W("ros2", 2.5e-3, jacobian_every=3),           # the default scene's setting
           # the Jacobian refreshed at a schedule's set-point jumps (and for a window after, there at a quarter
           # of the step with refresh_substeps 4), else every 8 steps
           W("ros2", 5e-3, jacobian_every=8, jacobian_refresh="on_sources", refresh_window=0.05),
           W("ros2", 1 / 150, jacobian_every=8, jacobian_refresh="on_sources", refresh_window=0.1, refresh_substeps=4),
           W("ros2", 1e-2, jacobian_every=8, jacobian_refresh="on_sources", refresh_window=0.1, refresh_substeps=4),
           # error control (issue 24): steps of the base step / 2^k chosen by ros2's embedded estimate
           W("ros2", 1e-2, jacobian_every=8, step_control="error", atol_q=3e-3, atol_v=3e-2, rtol=3e-2),
           W("ros2", 1e-2, jacobian_every=8, step_control="error", atol_q=1e-2, atol_v=1e-1, rtol=1e-1),
           W("ros2", 2e-2, jacobian_every=8, jacobian_refresh="on_sources", refresh_window=0.1),
           W("ros2", 2e-2, jacobian_every=8, jacobian_refresh="on_sources", refresh_window=0.1, error_filter=False)]
    if case != "walls":               # explicit methods need ~10 µs steps on the walls (λ ~ −3e5 /s)
        out = [({"name": "rk4"}, 1e-3), ({"name": "semi_implicit_euler"}, 1e-3)] + out
    else:
        out = [({"name": "rosenbrock2", "params": {"jacobian_every": 10}}, 2e-3)] + out
    if not quick:
        out += [W("ros2", 1e-2, jacobian_every=2), W("ros34pw2", 5e-3)]
    return out


def label(spec, dt):
    p = spec.get("params", {})
    return f"{spec['name']} dt={dt:g}" + "".join(f" {k}={v}" for k, v in p.items())


def main(quick: bool = False, only=(), match=()) -> list[dict]:
    import tempfile
    rows = []
    tmp = Path(tempfile.mkdtemp(prefix="held-"))
    for case, (fn, (ref_spec, ref_dt)) in CASES.items():
        if only and case not in only:
            continue
        t0 = time.perf_counter()
        ref = fn(ref_spec, ref_dt, tmp)
        print(f"\nheld case '{case}': reference {label(ref_spec, ref_dt)}: creep {ref['creep_m_s'] * 1e3:.4f} mm/s"
              + (f" (regularised law {ref['law_m_s'] * 1e3:.4f} mm/s)" if "law_m_s" in ref else "")
              + f"  [{time.perf_counter() - t0:.0f} s]", flush=True)
        print("| setting | RTF | creep mm/s | creep error | held |\n|---|---:|---:|---:|---|")
        for spec, dt in settings(quick, case):
            if match and not any(m in label(spec, dt) for m in match):
                continue
            m = fn(spec, dt, tmp)
            err = m["creep_m_s"] / ref["creep_m_s"] - 1.0
            held = m["completed"] and abs(err) <= 0.1
            print(f"| {label(spec, dt)} | {m['rtf']:.3g} | {m['creep_m_s'] * 1e3:.4f} | {err:+.1%} | "
                  f"{'yes' if held else 'NO'} |", flush=True)
            rows.append({"case": case, "setting": label(spec, dt), "reference_creep_m_s": ref["creep_m_s"],
                         "creep_error": err, **m})
    return rows


if __name__ == "__main__":
    import click

    @click.command()
    @click.option("--quick", is_flag=True)
    @click.option("--case", "only", multiple=True, help="slope, stop, walls")
    @click.option("--match", multiple=True, help="only the settings whose label contains one of these texts")
    @click.option("--json", "json_path", type=click.Path(dir_okay=False))
    def cli(quick, only, match, json_path):
        rows = main(quick, only, match)
        if json_path:
            import json
            Path(json_path).write_text(json.dumps(rows, indent=1) + "\n")

    cli()
