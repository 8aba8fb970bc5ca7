"""Multibody dynamics cost: one evaluation of the accelerations per robot, size and path.

    .venv/bin/python bench/multibody.py [--json FILE] [--designs all] [--modules 4,10,30,100] [--budget 0.05]

For each EELS design (snakesim.robots) and module count, one forward-dynamics
evaluation (q, v, τ -> q̈ at a random state) by Pinocchio, four ways:

  aba        ABA on the optimised model (fixed joints and massless links merged,
             counter-rotating pairs embedded as one DOF): what the simulator runs
  aba_unopt  ABA with every URDF link its own body (fixed joints as free revolute
             joints, rear screws as separate DOF: cost baseline, more DOF)
  mm         mass-matrix path: CRBA + non-linear effects + Cholesky on the
             optimised mimic model (the reference for screw pairs)
  mm_unopt   the same with every fixed joint a locked zero-DOF hinge (same
             dynamics, every link a body)

plus ``component``: the Multibody component's dynamics evaluation, output()
then derivative() (Python, torque assembly, ABA; derivative() copies what
output() solved) on the optimised model, and the same with an external wrench
on every link and the state's kinematics invalidated first (adds the numba link
kinematics and the wrench kernel). Times are µs, best of 9 batches; per-DOF figures divide by the
optimised model's nv. Before timing, the embedded and mimic models are checked
to give the same accelerations. BLAS runs single-threaded (as in a simulation
step; a threaded Cholesky of a few hundred unknowns mostly spins).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import json  # noqa: E402
import platform  # noqa: E402

import click  # noqa: E402
import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

from snakesim.components.multibody import Multibody  # noqa: E402
from snakesim.components.multibody.model import build_dynamics  # noqa: E402
from snakesim.components.multibody.report import baseline_models, time_call  # noqa: E402
from snakesim.framework import Harness  # noqa: E402
from snakesim.robots import DESIGNS  # noqa: E402


def _state(model, seed=0):
    rng = np.random.default_rng(seed)
    q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    return q, rng.standard_normal(model.nv), rng.standard_normal(model.nv)


BATCHES = 9


def _time(dyn, budget):
    q, v, tau = _state(dyn.model)
    return time_call(lambda: dyn.forward(q, v, tau), budget, BATCHES)


def measure(design: str, modules: int, budget: float) -> dict:
    h = Harness(Multibody, {"design": design, "modules": modules}, name="robot")
    c = h.c
    tree, arm = c.robot.tree, c.armature_user
    opt = c.dyn
    mm = build_dynamics(tree, "mimic_crba", arm, c.robot.groups) if c.mode == "embedded" else \
        type(opt)("mimic_crba", opt.model, opt.model.createData(), [])
    base = baseline_models(tree, arm)
    # the two optimised paths agree (exactness of the embedding) before we time them
    q, v, tau = _state(opt.model, 1)
    a1, a2 = opt.forward(q, v, tau), mm.forward(q, v, tau)
    agree = float(np.abs(a1 - a2).max() / max(1.0, np.abs(a2).max()))
    row = {"design": design, "modules": modules, "mode": c.mode, "nv": opt.model.nv,
           "bodies": opt.model.njoints - 1, "links": len(tree.links),
           "nv_aba_unopt": base["aba"].model.nv, "bodies_unopt": base["crba"].model.njoints - 1,
           "embedded_vs_mimic_rel_diff": agree,
           "aba_us": _time(opt, budget), "aba_unopt_us": _time(base["aba"], budget),
           "mm_us": _time(mm, budget), "mm_unopt_us": _time(base["crba"], budget)}
    h.x[:opt.model.nq] = q
    h.x[opt.model.nq:] = v
    dx = np.zeros(h.ndx)
    u, y = h.u, h.y

    def evaluate():
        c.output(0.0, h.x, u, y)
        c.derivative(0.0, h.x, u, dx)

    row["component_us"] = time_call(evaluate, budget, BATCHES)
    h.inputs.wrenches = np.ones((len(c.robot.links), 6))
    u, y = h.u, h.y
    fresh = u.cache.fresh            # the kinematics' "belong to this state" flag: cleared, as after a step
    row["component_wrench_us"] = time_call(lambda: (fresh.fill(False), evaluate()), budget, BATCHES)
    for k in ("aba", "mm", "component"):
        row[f"{k}_us_per_dof"] = row[f"{k}_us"] / row["nv"]
    return row


@click.command()
@click.option("--json", "json_path", type=click.Path(dir_okay=False), help="Also write the results here.")
@click.option("--designs", default="all", show_default=True, help="Comma-separated design names, or all.")
@click.option("--modules", default="4,10,30,100", show_default=True, help="Module counts.")
@click.option("--budget", default=0.1, show_default=True, help="Seconds of timing per figure.")
def main(json_path, designs, modules, budget):
    names = sorted(DESIGNS) if designs == "all" else designs.split(",")
    rows = []
    head = (f"{'design':15s} {'N':>4s} {'nv':>4s} {'bodies':>11s} {'aba':>8s} {'aba-unopt':>10s} {'mm':>9s} "
            f"{'mm-unopt':>9s} {'comp':>8s} {'comp+W':>8s} {'aba/dof':>8s} {'mm/dof':>8s} {'comp/dof':>8s}")
    click.echo("one dynamics evaluation, µs (bodies: optimised/unoptimised; per DOF: µs / nv)")
    click.echo(head)
    for d in names:
        for n in [int(s) for s in modules.split(",")]:
            r = measure(d, n, budget)
            rows.append(r)
            click.echo(f"{d:15s} {n:>4d} {r['nv']:>4d} {r['bodies']:>5d}/{r['bodies_unopt']:<5d} "
                       f"{r['aba_us']:>8.1f} {r['aba_unopt_us']:>10.1f} {r['mm_us']:>9.1f} {r['mm_unopt_us']:>9.1f} "
                       f"{r['component_us']:>8.1f} {r['component_wrench_us']:>8.1f} {r['aba_us_per_dof']:>8.3f} "
                       f"{r['mm_us_per_dof']:>8.3f} {r['component_us_per_dof']:>8.3f}")
            if r["embedded_vs_mimic_rel_diff"] > 1e-9:
                click.echo(f"  WARNING: embedded and mimic accelerations differ by {r['embedded_vs_mimic_rel_diff']:.2e}")
    if json_path:
        meta = {"python": platform.python_version(), "machine": platform.machine(), "numpy": np.__version__,
                "pinocchio": pin.__version__, "processor": platform.processor(), "budget_s": budget}
        with open(json_path, "w") as f:
            json.dump({"benchmark": "multibody", "meta": meta, "results": rows}, f, indent=2)
        click.echo(f"wrote {json_path}")


if __name__ == "__main__":
    main()
