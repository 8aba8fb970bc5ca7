"""What the rerun viewer sink costs a robot simulation: real-time factor with and without it.

    .venv/bin/python bench/viz_overhead.py [--scene contact-screw-drive] [--modules 4,10] [--duration 3]
                                           [--repeats 3] [--integrator NAME] [--configs none,viz,unbatched]
                                           [--json FILE]

For each module count the scene runs (same session, same steps) in three
configurations, each the best of ``--repeats`` runs after one warm-up:

  none        no viewer
  viz         ``--viz save FILE.rrd`` as the CLI adds it: 30 Hz frames; link
              transforms, signal plots and contacts batched by send_columns
              (2 s of frames per batch when saving)
  unbatched   the same with flush_frames = 1 (one send_columns per entity per
              frame): what batching saves

Reported: real-time factor (simulated s per wall s of the step loop), the
overhead against ``none`` in % of wall time and in µs per viewer frame, the
.rrd size. The scene defaults to assemblies/contact-screw-drive.yaml (robot
on flat ice, SDF screw contact), falling back to robot-zero-g (multibody only).
"""

from __future__ import annotations

import json
import platform
import tempfile
from pathlib import Path

import click

from snakesim.components.viz.attach import attach_viewer
from snakesim.components.viz.target import VizTarget
from snakesim.framework.assembly import resolve
from snakesim.framework.registry import default_registry
from snakesim.framework.session import Session

CONFIGS = ("none", "viz", "unbatched")


def _session(scene: str, modules: int, duration: float, config: str, rrd: Path, reg,
             integrator: str | None = None) -> Session:
    sim = {"duration": duration} | ({"integrator": integrator} if integrator else {})
    r = resolve(scene, search_path=reg.assembly_paths(), overrides=[f"robot.modules={modules}"], sim_overrides=sim)
    if config != "none":
        attach_viewer(r, VizTarget("save", str(rrd)), reg,
                      params={"flush_frames": 1} if config == "unbatched" else None)
    return Session(r, reg)


def measure(scene: str, modules: int, duration: float, repeats: int, tmp: Path, reg,
            integrator: str | None = None, configs=CONFIGS) -> list[dict]:
    rows = []
    base_wall = None
    for config in configs:
        rrd = tmp / f"{config}-{modules}.rrd"
        s = _session(scene, modules, duration, config, rrd, reg, integrator)
        s.run()                                            # warm-up: caches, first recording
        walls, summary = [], None
        for _ in range(repeats):
            summary = s.run().summary
            walls.append(summary["wall_time_s"])
        wall = min(walls)
        frames = 0
        if config != "none":
            viz = s.plan.components["viz"]
            viz.close()
            frames = int(round(summary["sim_time_s"] * viz.rate)) + 1
        base_wall = wall if config == "none" else base_wall
        rows.append({
            "scene": scene, "modules": modules, "config": config, "sim_time_s": summary["sim_time_s"],
            "steps": summary["steps"], "wall_s": wall, "real_time_factor": summary["sim_time_s"] / wall,
            "frames": frames,
            "overhead_pct": None if config == "none" else 100.0 * (wall - base_wall) / base_wall,
            "us_per_frame": None if config == "none" else 1e6 * (wall - base_wall) / frames,
            "rrd_bytes": rrd.stat().st_size if rrd.exists() else None,
        })
    return rows


@click.command()
@click.option("--scene", default=None, help="Scene (default contact-screw-drive, else robot-zero-g).")
@click.option("--modules", default="4,10", help="Comma-separated module counts.")
@click.option("--duration", default=3.0, type=float, help="Simulated s per run.")
@click.option("--repeats", default=3, type=int, help="Timed runs per configuration (best counts).")
@click.option("--integrator", default=None, help="Override sim.integrator (e.g. semi_implicit_euler).")
@click.option("--configs", default=",".join(CONFIGS), help=f"Comma-separated subset of {', '.join(CONFIGS)} "
              "(none first: the others are measured against it).")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), help="Write the figures here.")
def main(scene, modules, duration, repeats, integrator, configs, json_path):
    reg = default_registry()
    if scene is None:
        names = {Path(str(p)).stem for d in reg.assembly_paths() for p in Path(str(d)).glob("*.yaml")}
        scene = "contact-screw-drive" if "contact-screw-drive" in names else "robot-zero-g"
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for m in (int(s) for s in modules.split(",")):
            rows += measure(scene, m, duration, repeats, Path(tmp), reg, integrator, configs.split(","))
    click.echo(f"scene {scene}, {duration:g} s simulated per run, best of {repeats}"
               + (f", integrator {integrator}" if integrator else ""))
    click.echo(f"{'modules':>7} {'config':<10} {'wall s':>8} {'RTF':>7} {'frames':>6} {'overhead':>9} "
               f"{'µs/frame':>9} {'rrd MB':>7}")
    for r in rows:
        ov = "" if r["overhead_pct"] is None else f"{r['overhead_pct']:+.1f}%"
        us = "" if r["us_per_frame"] is None else f"{r['us_per_frame']:.0f}"
        mb = "" if r["rrd_bytes"] is None else f"{r['rrd_bytes'] / 1e6:.2f}"
        click.echo(f"{r['modules']:>7} {r['config']:<10} {r['wall_s']:>8.3f} {r['real_time_factor']:>7.3f} "
                   f"{r['frames']:>6} {ov:>9} {us:>9} {mb:>7}")
    if json_path:
        Path(json_path).parent.mkdir(parents=True, exist_ok=True)
        Path(json_path).write_text(json.dumps({"machine": platform.processor() or platform.machine(),
                                               "python": platform.python_version(), "rows": rows}, indent=2) + "\n")
        click.echo(f"wrote {json_path}")


if __name__ == "__main__":
    main()
