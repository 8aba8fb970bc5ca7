"""Before / after: the same scene setting timed in two source trees, in turns, each against MuJoCo.

    git archive COMMIT assemblies campaigns components configs framework robots terrains \\
        | (mkdir -p /tmp/before/snakesim && tar -x -C /tmp/before/snakesim)
    .venv/bin/python bench/ab_speed.py --before /tmp/before [--modules 10] [--dt 0.005] [--jacobian-every 3]
                                       [--duration 10] [--rounds 3] [--repeats 3] [--json FILE]

Each round runs one child process on the tree at --before (its ``snakesim`` package first on
PYTHONPATH: DIR/snakesim/{framework,components,...}) and one on this working tree, alternately. A
child builds the default scene (surface-screw-traverse) with ``robot.modules``, the ros2 W-method at
--dt and --jacobian-every, runs it once to warm up, then --repeats runs each followed by a MuJoCo
run of the screw snake with as many modules (bench/interleaved.py: wall clock and CPU time). Printed:
per child the RTF and the ratio to MuJoCo (median by CPU time); at the end each tree's median over
its children, and after / before. Machine load moves both trees' figures alike only when they run in
turns, hence the rounds.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

import click

HERE = Path(__file__).resolve().parent
CHILD = r"""
import json, os, sys
for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(v, "1")
sys.path.insert(0, {bench!r})
sys.path.insert(0, {validation!r})
from validation_scenes import session
from interleaved import compare
import snakesim.framework
a = json.loads(sys.argv[1])
s = session("surface-screw-traverse", ["robot.modules=%d" % a["modules"]],
            {{"duration": a["duration"], "dt": a["dt"],
             "integrator": {{"name": "rosenbrock_w", "params": {{"method": "ros2", "jacobian_every": a["je"]}}}}}})
s.run()
# CPU time around the whole run call for both trees alike (an older tree's summary has no cpu_time_s)
strip = lambda sm: {{k: v for k, v in sm.items() if k != "cpu_time_s"}}
res = compare(lambda: strip(s.run().summary), modules=a["modules"], mujoco_dt=1e-3 if a["modules"] <= 10 else 2e-3,
              mujoco_duration=5.0 if a["modules"] <= 10 else 1.0, repeats=a["repeats"])
res["tree"] = os.path.dirname(os.path.dirname(snakesim.framework.__file__))
print("RESULT " + json.dumps(res))
"""


def child(tree: str | None, args: dict) -> dict:
    env = dict(os.environ)
    if tree:
        env["PYTHONPATH"] = tree + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    code = CHILD.format(bench=str(HERE), validation=str(HERE.parent / "tests" / "validation"))
    out = subprocess.run([sys.executable, "-c", code, json.dumps(args)], env=env, capture_output=True, text=True)
    lines = [ln for ln in out.stdout.splitlines() if ln.startswith("RESULT ")]
    if out.returncode or not lines:
        raise RuntimeError(f"child on {tree or 'this tree'} failed:\n{out.stderr[-3000:]}")
    return json.loads(lines[-1][7:])


@click.command()
@click.option("--before", "before", required=True, type=click.Path(exists=True, file_okay=False),
              help="a directory holding snakesim/{framework,components,...} of the tree to compare with")
@click.option("--modules", default=10, show_default=True)
@click.option("--dt", default=0.005, show_default=True)
@click.option("--jacobian-every", "je", default=3, show_default=True)
@click.option("--duration", default=10.0, show_default=True, help="simulated s per run")
@click.option("--rounds", default=3, show_default=True, help="child processes per tree, in turns")
@click.option("--repeats", default=3, show_default=True, help="interleaved snakesim/MuJoCo pairs per child")
@click.option("--json", "json_path", type=click.Path(dir_okay=False))
def main(before, modules, dt, je, duration, rounds, repeats, json_path):
    args = {"modules": modules, "dt": dt, "je": je, "duration": duration, "repeats": repeats}
    print(f"surface-screw-traverse, {modules} modules, rosenbrock_w ros2 dt = {dt * 1e3:g} ms, jacobian_every {je}, "
          f"{duration:g} s per run; MuJoCo Euler {'1' if modules <= 10 else '2'} ms")
    got = {"before": [], "after": []}
    for i in range(rounds):
        for name, tree in (("before", str(Path(before).resolve())), ("after", None)):
            r = child(tree, args)
            got[name].append(r)
            c = r.get("ratio_cpu", {}).get("median")
            w = r.get("ratio_wall", {}).get("median")
            print(f"round {i + 1} {name:6s} ({r['tree']}): RTF {r['snakesim_rtf_wall_best']:.3g} wall / "
                  f"{r['snakesim_rtf_cpu_best']:.3g} CPU; x MuJoCo median wall {w:.2f}, CPU {c:.2f}", flush=True)
    summary = {}
    for name, rs in got.items():
        summary[name] = {k: statistics.median(r[k] for r in rs) for k in ("snakesim_rtf_cpu_best",
                                                                          "snakesim_rtf_wall_best")}
        if all("ratio_cpu" in r for r in rs):
            summary[name]["x_mujoco_cpu"] = statistics.median(r["ratio_cpu"]["median"] for r in rs)
            summary[name]["x_mujoco_wall"] = statistics.median(r["ratio_wall"]["median"] for r in rs)
    b, a = summary["before"], summary["after"]
    print(f"before: RTF {b['snakesim_rtf_cpu_best']:.3g} (CPU), x MuJoCo {b.get('x_mujoco_cpu', float('nan')):.2f} "
          f"(CPU) / {b.get('x_mujoco_wall', float('nan')):.2f} (wall)")
    print(f"after:  RTF {a['snakesim_rtf_cpu_best']:.3g} (CPU), x MuJoCo {a.get('x_mujoco_cpu', float('nan')):.2f} "
          f"(CPU) / {a.get('x_mujoco_wall', float('nan')):.2f} (wall)")
    print(f"after / before: {a['snakesim_rtf_cpu_best'] / b['snakesim_rtf_cpu_best']:.3f} (CPU-time RTF, medians)")
    if json_path:
        Path(json_path).write_text(json.dumps({"args": args, "runs": got, "summary": summary}, indent=1) + "\n")


if __name__ == "__main__":
    main()
