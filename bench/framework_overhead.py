"""Per-step scheduler overhead per component: the framework vs the same arithmetic in plain numpy.

The system is a loop of N trivial components that cannot be pruned: an
integrator block (state x, ẋ = u) whose output runs through N ``gain``
blocks (n = 1; the first k = −1, the rest k = 1) back into its own input,
so ẋ = −x. It runs with ``semi_implicit_euler``, one evaluation of every
component per step. The reference is a hand-written loop doing the same
arithmetic on the same preallocated arrays: one ``np.multiply(..., out=)``
per gain, the integrator's output copy, its derivative and the Euler update.
Both end in bit-identical states (checked).

Reported per step and per component per step, best of ``--repeats``, both
measured in this run with the garbage collector off:

    framework   µs per component per step through the scheduler
    numpy       µs per component per step, hand-written
    overhead    (framework − numpy) / N: what the framework adds per component
    ratio       framework / numpy

Target: the framework adds at most 2 µs per component per step.

    python bench/framework_overhead.py [--n 50] [--steps 20000] [--repeats 5] [--json FILE]
"""

from __future__ import annotations

import argparse
import gc
import json
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from snakesim.framework import Component, ContinuousState, Input, Output, Params
from snakesim.framework.registry import build_registry
from snakesim.framework.session import load_session

TARGET_US = 2.0
DT = 1e-3


class BenchIntegrator(Component[Params]):
    """ẋ = u, y = x (n = 1): the one state that keeps the gain chain alive."""

    type_name = "bench_integrator"
    u = Input(shape=1, unit=None)
    y = Output(shape=1, unit=None, feedthrough=())

    def continuous_state(self):
        return ContinuousState(np.ones(1))

    def output(self, t, x, u, y):
        y.y[:] = x

    def derivative(self, t, x, u, dx):
        dx[:] = u.u


def assembly_text(n: int, steps: int) -> str:
    lines = ["description: framework overhead benchmark - an integrator fed back through a chain of gains",
             f"sim: {{duration: {steps * DT!r}, dt: {DT!r}, integrator: semi_implicit_euler}}",
             "components:", "  x: {type: bench_integrator}"]
    lines += [f"  g{i}: {{type: gain, params: {{k: {-1.0 if i == 0 else 1.0}, n: 1}}}}" for i in range(n)]
    lines += ["connections:", "  - x.y -> g0.u"]
    lines += [f"  - g{i - 1}.y -> g{i}.u" for i in range(1, n)]
    lines += [f"  - g{n - 1}.y -> x.u"]
    return "\n".join(lines) + "\n"


def framework_session(n: int, steps: int, folder: Path):
    reg = build_registry(load_entry_points=False)
    reg.add_component(BenchIntegrator)
    path = folder / f"overhead-{n}.yaml"
    path.write_text(assembly_text(n, steps))
    session = load_session(path, registry=reg)
    assert not session.plan.pruned, session.plan.pruned
    return session


def numpy_loop(n: int, steps: int) -> tuple[float, float]:
    """The same arithmetic by hand; returns (seconds, final x)."""
    x = np.ones(1)
    y = np.zeros(1)                       # the integrator's output buffer
    bufs = [np.zeros(1) for _ in range(n)]
    ks = [-1.0 if i == 0 else 1.0 for i in range(n)]
    dx, dxh = np.zeros(1), np.zeros(1)
    multiply, copyto, add = np.multiply, np.copyto, np.add
    t0 = time.perf_counter()
    for step in range(steps):
        copyto(y, x)                      # integrator output: y = x
        src = y
        for buf, k in zip(bufs, ks):      # the gains
            multiply(src, k, out=buf)
            src = buf
        copyto(dx, src)                   # derivative: ẋ = u
        t = step * DT                     # h = t1 − t0 as the integrator takes it (not exactly DT)
        multiply(dx, (t + DT) - t, out=dxh)   # semi-implicit Euler, first-order state: x += h·ẋ
        add(x, dxh, out=x)
    return time.perf_counter() - t0, float(x[0])


def measure(n: int, steps: int, repeats: int, folder: Path) -> dict:
    # correctness first: both loops end in the same state, bit for bit
    check_steps = 1000
    s = framework_session(n, check_steps, folder)
    s.run()
    _, x_ref = numpy_loop(n, check_steps)
    x_fw = float(s.plan.X[0])
    if x_fw != x_ref:
        raise SystemExit(f"framework and numpy loops disagree after {check_steps} steps: {x_fw!r} vs {x_ref!r}")

    session = framework_session(n, steps, folder)
    fw, ref = [], []
    gc_was = gc.isenabled()
    gc.disable()
    try:
        for _ in range(repeats):
            t0 = time.perf_counter()
            result = session.simulator.run(steps * DT)
            fw.append(time.perf_counter() - t0)
            assert result.summary["steps"] == steps
            ref.append(numpy_loop(n, steps)[0])
    finally:
        if gc_was:
            gc.enable()
    fw_step, np_step = min(fw) / steps * 1e6, min(ref) / steps * 1e6
    return {
        "components": n,
        "steps": steps,
        "repeats": repeats,
        "framework_us_per_step": fw_step,
        "numpy_us_per_step": np_step,
        "framework_us_per_component_step": fw_step / n,
        "numpy_us_per_component_step": np_step / n,
        "overhead_us_per_component_step": (fw_step - np_step) / n,
        "ratio": fw_step / np_step,
        "target_us": TARGET_US,
        "target_met": (fw_step - np_step) / n <= TARGET_US,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[50], help="gain-chain lengths (default 50)")
    ap.add_argument("--steps", type=int, default=20000, help="steps per timed run")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs; the best counts")
    ap.add_argument("--json", type=Path, help="also write the figures here")
    args = ap.parse_args(argv)

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.n:
            rows.append(measure(n, args.steps, args.repeats, Path(tmp)))

    print(f"framework overhead: integrator + N gains, semi_implicit_euler, {args.steps} steps, "
          f"best of {args.repeats}")
    head = f"{'N':>5} {'framework':>12} {'numpy':>12} {'framework':>12} {'numpy':>12} {'overhead':>12} {'ratio':>7}  target"
    unit = f"{'':>5} {'µs/step':>12} {'µs/step':>12} {'µs/comp/step':>12} {'µs/comp/step':>12} {'µs/comp/step':>12} {'':>7}"
    print(head)
    print(unit)
    for r in rows:
        ok = "met" if r["target_met"] else "NOT met"
        print(f"{r['components']:>5} {r['framework_us_per_step']:>12.2f} {r['numpy_us_per_step']:>12.2f} "
              f"{r['framework_us_per_component_step']:>12.3f} {r['numpy_us_per_component_step']:>12.3f} "
              f"{r['overhead_us_per_component_step']:>12.3f} {r['ratio']:>7.2f}  "
              f"≤ {TARGET_US:g} µs: {ok}")
    fit = None
    if len({r["components"] for r in rows}) >= 2:
        # split each loop's time per step into a fixed part and a part per component
        ns = np.array([r["components"] for r in rows], dtype=float)
        fw_slope, fw_fixed = np.polyfit(ns, [r["framework_us_per_step"] for r in rows], 1)
        np_slope, np_fixed = np.polyfit(ns, [r["numpy_us_per_step"] for r in rows], 1)
        fit = {"framework_us_per_component": fw_slope, "framework_us_fixed_per_step": fw_fixed,
               "numpy_us_per_component": np_slope, "numpy_us_fixed_per_step": np_fixed,
               "marginal_overhead_us_per_component": fw_slope - np_slope}
        print(f"fit over N: framework {fw_fixed:.2f} µs/step + {fw_slope:.3f} µs/component, "
              f"numpy {np_fixed:.2f} µs/step + {np_slope:.3f} µs/component; "
              f"marginal overhead {fw_slope - np_slope:.3f} µs per component per step")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        doc = {"benchmark": "framework_overhead", "python": sys.version.split()[0], "numpy": np.__version__,
               "machine": platform.machine(), "processor": platform.processor() or platform.machine(),
               "results": rows, "fit": fit}
        args.json.write_text(json.dumps(doc, indent=2) + "\n")
        print(f"wrote {args.json}")
    return 0 if all(r["target_met"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
