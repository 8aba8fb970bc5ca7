"""The implicit step's linear algebra per multibody: the link-tree (O(links)) factorisation against the
dense LU it replaced, in one process, on the default scene's state after a short drive.

    .venv/bin/python bench/articulated_solve.py [--modules 10,100] [--repeats 50]

Per module count: ms per Jacobian assembly (``Linearization.assemble``: contact blocks, torque
slopes, and M: kept per link on the tree, or CRBA + composite-rigid-body sums for the dense LU),
per factorisation (c = γh at 5 ms) and per solve (I − cJ)⁻¹ r, and how far the two solves agree
(max |difference| / max |dense|). The dense path is the multibody's fallback
(``structured_solve = False``) with Pinocchio's CRBA for M, as before the tree.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import time  # noqa: E402

import click  # noqa: E402
import numpy as np  # noqa: E402

from snakesim.framework.integrators.rosenbrock_w import GAMMA_ROS2  # noqa: E402
from snakesim.framework.linearization import Linearization  # noqa: E402
from snakesim.framework.session import load_session  # noqa: E402


def _time(fn, repeats):
    fn()
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        for _ in range(repeats):
            fn()
        best = min(best, (time.perf_counter() - t0) / repeats)
    return best * 1e3


def row(modules: int, repeats: int) -> dict:
    s = load_session("surface-screw-traverse", overrides=[f"robot.modules={modules}", "settle=0.2"],
                     sim_overrides={"duration": 0.4, "integrator": "rosenbrock_w", "dt": 5e-3})
    s.run()
    p, t, c = s.plan, 0.4, GAMMA_ROS2 * 5e-3
    p.f(t, p.X)
    mb = p.components["robot"]
    r = np.random.default_rng(0).standard_normal(p.ndx)
    out = {}
    for name, structured in (("tree", True), ("dense", False)):
        mb.structured_solve = structured
        tree_m = mb.dyn.tree_mass_matrix
        if not structured:
            mb.dyn.tree_mass_matrix = None            # CRBA, as the dense path had it
        lin = Linearization(p)
        k = np.zeros(p.ndx)
        asm = _time(lambda: lin.assemble(t), repeats)
        fac = _time(lambda: lin.factor(c), repeats)
        sol = _time(lambda: lin.solve(r, k), repeats)
        out[name] = {"assemble_ms": asm, "factor_ms": fac, "solve_ms": sol, "k": k.copy()}
        mb.dyn.tree_mass_matrix = tree_m
    mb.structured_solve = True
    agree = np.abs(out["tree"].pop("k") - out["dense"]["k"]).max() / np.abs(out["dense"].pop("k")).max()
    return {"modules": modules, "nv": mb._nv, **{f"{n}_{k}": v for n in out for k, v in out[n].items()},
            "agreement": agree}


@click.command()
@click.option("--modules", default="10,100")
@click.option("--repeats", default=50)
def main(modules, repeats):
    print("ms per call, best of 3 x repeats; agreement: max |k_tree - k_dense| / max |k_dense|")
    print(f"{'modules':>7s} {'nv':>4s} | {'assemble':>8s} {'factor':>8s} {'solve':>8s} (tree) | "
          f"{'assemble':>8s} {'factor':>8s} {'solve':>8s} (dense LU) | agreement")
    for m in map(int, modules.split(",")):
        x = row(m, repeats)
        print(f"{m:7d} {x['nv']:4d} | {x['tree_assemble_ms']:8.3f} {x['tree_factor_ms']:8.3f} {x['tree_solve_ms']:8.3f}"
              f"        | {x['dense_assemble_ms']:8.3f} {x['dense_factor_ms']:8.3f} {x['dense_solve_ms']:8.3f}"
              f"            | {x['agreement']:.1e}", flush=True)


if __name__ == "__main__":
    main()
