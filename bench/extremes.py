"""Extremes: where each integrator stops being stable, and what the framework does then.

    .venv/bin/python bench/extremes.py [--quick] [--json FILE]

Scene: the default traverse (surface-screw-traverse, all screws forward from 0.1 s), short
horizon. For every integrator and contact stiffness k (1e3 .. 1e8 N/m, the `material.k`
override of the contact) the base step is doubled from 0.125 ms until the run fails; the
table gives the largest step that ran clean. A failure is what the framework reports — a
non-finite-state stop naming the component, or the integrator giving up — or the robot
leaving the physical range (its CoM sinking below the ice or flying off: `unphysical`),
never a silent NaN: every row states how the first failing step ended. The robot starts
touching the ice without overlap, so a stiff contact is not kicked by its initial state.
Also: a 100-module robot and near-massless links (link masses scaled by --mass-scale through
the robot generator when it supports it; otherwise reported as not run).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "validation"))
from validation_scenes import run  # noqa: E402

INTEGRATORS = {"semi_implicit_euler": {}, "rk4": {}, "dopri5": {"rtol": 1e-4, "atol": 1e-6},
               "rosenbrock2": {"jacobian_every": 5}}


def attempt(k, integ, dt, horizon, modules, extra=()):
    sets = ["settle=0.1", f"phase={horizon}", f"robot.modules={modules}",
            f"components.contact.params.material.k={k}",
            "components.robot.params.base_position=[0.0, 0.0, 0.09]", *extra]   # touching, no initial overlap
    sim = {"duration": horizon, "dt": dt, "integrator": {"name": integ, "params": INTEGRATORS[integ]}}
    try:
        s, r = run("surface-screw-traverse", sets, sim,
                   patch=lambda res: res.sim.__setattr__("record_rate", None))
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
    return {"ok": True, "how": "ok", "rtf": sm["real_time_factor"]}


@click.command()
@click.option("--quick", is_flag=True)
@click.option("--json", "json_path", type=click.Path(dir_okay=False))
def main(quick, json_path):
    horizon, modules = (0.512, 4) if quick else (1.024, 10)   # whole steps for every dt tried
    ks = [1e3, 1e5, 1e7] if quick else [1e3, 1e4, 1e5, 1e6, 1e7, 1e8]
    dts = [1.25e-4 * 2 ** i for i in range(8 if quick else 9)]
    rows = []
    print(f"stable step per integrator and contact stiffness ({modules} modules, {horizon:g} s)\n")
    print("| integrator | k N/m | largest clean dt s | RTF there | first failing dt s | how it failed |\n|---|---:|---:|---:|---:|---|")
    for integ in INTEGRATORS:
        for k in ks:
            best, fail = None, None
            for dt in dts:
                if integ == "rosenbrock2" and dt < 1e-3:      # FD Jacobian: too costly at small steps
                    continue
                a = attempt(k, integ, dt, horizon, modules)
                if a["ok"]:
                    best = (dt, a)
                else:
                    fail = (dt, a)
                    break
            row = {"integrator": integ, "k": k, "max_clean_dt": best[0] if best else None,
                   "rtf": best[1]["rtf"] if best else None,
                   "first_fail_dt": fail[0] if fail else None, "how": fail[1]["how"] if fail else "none up to the largest step"}
            rows.append(row)
            f = lambda v, fmt: "—" if v is None else format(v, fmt)  # noqa: E731
            print(f"| {integ} | {k:.0e} | {f(row['max_clean_dt'], 'g')} | {f(row['rtf'], '.3g')} | "
                  f"{f(row['first_fail_dt'], 'g')} | {row['how']} |", flush=True)
    print("\n100-module EELS 1.0 (rk4 and semi_implicit_euler, dt = 0.5 ms, 0.1 s):")
    for integ in ("semi_implicit_euler", "rk4"):
        a = attempt(1e5, integ, 5e-4, 0.1, 100, ["crescent_bend=0.03"])
        rows.append({"case": "100 modules", "integrator": integ, **a})
        print(f"  {integ}: {a['how']}, RTF {a.get('rtf', float('nan')):.3g}")
    if json_path:
        Path(json_path).parent.mkdir(parents=True, exist_ok=True)
        Path(json_path).write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
