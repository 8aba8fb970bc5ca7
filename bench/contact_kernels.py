"""Contact kernel speed: numpy (vectorised) vs numba (njit, in place), per call.

    .venv/bin/python bench/contact_kernels.py [--json FILE] [--sizes 10,40,200,1000]

Kernel: normal (eq. 2) + anisotropic friction (eq. 6, ‖e_v‖ = a + b F_n, sqrt
regularisation) for n contact points; and the point-forces-to-body-wrenches reduction
(n points onto n/8 bodies). Times are the best of 7 repeats of an autoranged loop; the
numba kernel is compiled (and cached) before timing.
"""

from __future__ import annotations

import json
import platform
import timeit

import click
import numpy as np

from snakesim.components.contact import body_wrenches, body_wrenches_nb, contact_forces, contact_forces_nb
from snakesim.components.contact.kernels import MODES


def _best(fn, repeat=7):
    t = timeit.Timer(fn)
    number, _ = t.autorange()
    return min(t.repeat(repeat=repeat, number=number)) / number


def case(n, seed=0):
    rng = np.random.default_rng(seed)
    normal = rng.normal(size=(n, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    return (rng.uniform(-0.002, 0.004, n), normal, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)))


@click.command()
@click.option("--json", "json_path", type=click.Path(dir_okay=False), help="Also write the results here.")
@click.option("--sizes", default="10,40,200,1000", show_default=True, help="Contact point counts.")
def main(json_path, sizes):
    rows = []
    for n in [int(s) for s in sizes.split(",")]:
        depth, normal, vel, e = case(n)
        params = (1e5, 1e3, 0.25, 1.8, 0.025, 1e-3)
        out_f, out_fn = np.empty((n, 3)), np.empty(n)
        contact_forces_nb(depth, normal, vel, e, *params, MODES["sqrt"], 1e-3, out_f, out_fn)   # compile
        t_np = _best(lambda: contact_forces(depth, normal, vel, e, *params, "sqrt"))
        t_nb = _best(lambda: contact_forces_nb(depth, normal, vel, e, *params, 0, 1e-3, out_f, out_fn))
        nb = max(1, n // 8)
        idx = np.arange(n) % nb
        origins = np.zeros((nb, 3))
        out_w = np.empty((nb, 6))
        body_wrenches_nb(normal, vel, origins, idx, out_w)
        w_np = _best(lambda: body_wrenches(normal, vel, origins, idx))
        w_nb = _best(lambda: body_wrenches_nb(normal, vel, origins, idx, out_w))
        rows.append({"n": n, "forces_numpy_us": t_np * 1e6, "forces_numba_us": t_nb * 1e6,
                     "wrench_numpy_us": w_np * 1e6, "wrench_numba_us": w_nb * 1e6})
    click.echo(f"{'n':>6} {'forces numpy':>14} {'forces numba':>14} {'speed-up':>9} {'wrench numpy':>14} {'wrench numba':>14}")
    for r in rows:
        click.echo(f"{r['n']:>6} {r['forces_numpy_us']:>11.2f} µs {r['forces_numba_us']:>11.2f} µs "
                   f"{r['forces_numpy_us'] / r['forces_numba_us']:>8.1f}x {r['wrench_numpy_us']:>11.2f} µs "
                   f"{r['wrench_numba_us']:>11.2f} µs")
    if json_path:
        meta = {"python": platform.python_version(), "machine": platform.machine(), "numpy": np.__version__,
                "processor": platform.processor()}
        with open(json_path, "w") as f:
            json.dump({"benchmark": "contact_kernels", "meta": meta, "results": rows}, f, indent=2)
        click.echo(f"wrote {json_path}")


if __name__ == "__main__":
    main()
