"""``snakesim sweep SCENE --dispersions FILE.yaml -n N``: a Monte Carlo campaign or parameter sweep.

Registered through the ``snakesim_add_commands`` hook (hookimpl below; the
entry point ``campaigns`` names :mod:`snakesim.campaigns.plugin`).
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from snakesim.framework import SnakesimError, hookimpl
from snakesim.framework.outcomes import SWEEP_RUN_FAILED


def _positive(ctx, param, value):
    if value is not None and value <= 0:
        raise click.BadParameter(f"must be > 0, got {value:g}")
    return value


@click.command("sweep")
@click.argument("assembly")
@click.option("--dispersions", "dispersions", required=True, type=click.Path(dir_okay=False),
              help="Dispersion file: {seed, dispersions: {--set path: {dist: ...}}, metrics, success} "
                   "(docs/campaigns.md).")
@click.option("-n", "--runs", "n", type=int, required=True, help="Number of runs N (> 0).")
@click.option("--seed", type=int, help="Overrides the file's seed (default 0). Run i's sample depends only on "
                                       "(seed, i), except LHS and grid designs, which are over all N.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Campaign folder (default: sweeps/<scene>-<dispersion file>). An existing one is resumed.")
@click.option("--set", "sets", multiple=True, metavar="KEY.PATH=VALUE", help="Fixed override for every run.")
@click.option("--config", "config", multiple=True, type=click.Path(dir_okay=False),
              help="Config file merged over the assembly (repeatable).")
@click.option("--duration", type=float, callback=_positive, help="Simulated time per run, s.")
@click.option("--dt", type=float, callback=_positive, help="Base step, s.")
@click.option("--integrator", help="Integrator for every run.")
@click.option("--workers", type=int, help="Local process pool size (default: every core).")
@click.option("--scheduler", metavar="tcp://HOST:PORT", help="Run on this Dask scheduler's workers.")
@click.option("--dask-local", "dask_local", type=int, metavar="N",
              help="Start a Dask LocalCluster of N single-threaded worker processes and run on it.")
@click.option("--connect-timeout", type=float, default=10.0, show_default=True, callback=_positive,
              help="Seconds to reach --scheduler before giving up.")
@click.option("--run-timeout", type=float, callback=_positive,
              help="Wall-time limit per run (build + run), s; a run past it is recorded as 'timeout'.")
@click.option("--save-runs", is_flag=True, help="Write each run's signals.csv, summary.json, config.yaml "
                                                "to OUT/runs/run-NNNNN/.")
@click.option("--retry-failed", is_flag=True, help="On resume, run again the runs recorded as error or timeout.")
@click.option("--fresh", is_flag=True, help="Discard OUT's earlier records and start over.")
@click.option("--no-plots", is_flag=True, help="Skip the PNG plots (the table and ranking are still written).")
@click.option("--quiet", is_flag=True, help="No progress line.")
def sweep(assembly, dispersions, n, seed, out_dir, sets, config, duration, dt, integrator, workers, scheduler,
          dask_local, connect_timeout, run_timeout, save_runs, retry_failed, fresh, no_plots, quiet):
    """Run N variations of ASSEMBLY (a scene name or YAML path) with parameters drawn from a dispersion
    file; write OUT/results.parquet and .csv (a row per run, with its status, outcome and failure kind),
    summary.json, sensitivity.csv and plots. Exits 0 when every run is a success (its status is in the
    dispersion file's success list, default ok), 20 when at least one is not."""
    from .backends import dask_local as start_dask_local, dask_scheduler, local_pool
    from .campaign import prepare, run_campaign
    from .report import summarize
    from .runner import SceneSpec
    from snakesim.framework.run_files import check_writable_dir

    if sum(x is not None for x in (workers, scheduler, dask_local)) > 1:
        raise click.UsageError("choose one back end: --workers (local pool), --scheduler or --dask-local")
    if workers is not None and workers < 1:
        raise click.BadParameter(f"must be >= 1, got {workers}", param_hint="--workers")
    if dask_local is not None and dask_local < 1:
        raise click.BadParameter(f"must be >= 1, got {dask_local}", param_hint="--dask-local")
    scene = SceneSpec(assembly=assembly, config_files=tuple(str(Path(c).resolve()) for c in config),
                      sets=tuple(sets),
                      sim=tuple((k, v) for k, v in (("duration", duration), ("dt", dt), ("integrator", integrator))
                                if v is not None))
    out = Path(out_dir) if out_dir else Path("sweeps") / f"{Path(assembly).stem}-{Path(dispersions).stem}"
    try:
        plan = prepare(scene, dispersions, n, seed)        # every check, before any run or back end
        check_writable_dir(out, "--out")                   # where the campaign writes, before any run
        backend = (dask_scheduler(scheduler, connect_timeout) if scheduler else
                   start_dask_local(dask_local) if dask_local else local_pool(workers))
    except SnakesimError as e:
        raise click.ClickException(str(e)) from None
    if not quiet:
        click.echo(f"sweep {assembly}: {n} runs, {len(plan.dispersions.dispersions)} dispersed parameters, "
                   f"seed {plan.seed}, on {backend.description} -> {out}", err=True)
    try:
        with backend:
            res = run_campaign(plan, out, backend, save_runs=save_runs, timeout_s=run_timeout,
                               retry_failed=retry_failed, fresh=fresh, quiet=quiet)
    except KeyboardInterrupt:
        click.echo(f"\ninterrupted: finished runs are in {out}/runs.jsonl and the table; "
                   "run the same command again to resume", err=True)
        sys.exit(130)
    except SnakesimError as e:
        raise click.ClickException(str(e)) from None
    try:
        summary = summarize(res["table"], out, plan.dispersions.success, plots=not no_plots,
                            curves=plan.dispersions.curves)
    except SnakesimError as e:      # a full or read-only disk: the file and the cause (framework/output_files.py)
        raise click.ClickException(str(e)) from None
    counts = ", ".join(f"{v} {k}" for k, v in summary["by_status"].items())
    click.echo(f"{summary['runs']} runs ({counts}); success rate {summary['success_rate']:.1%}", err=True)
    for r in summary["sensitivity_top"][:5]:
        click.echo(f"  rho = {r['spearman_rho']:+.2f}  {r['parameter']} -> {r['metric']}", err=True)
    click.echo(f"wrote {out}/results.parquet, results.csv, summary.json, sensitivity.csv"
               + "".join(f", {name}" for name in summary.get("plots", [])), err=True)
    failed = summary["failed"]
    if failed:
        # a script or CI tells a campaign with failed runs from a clean one (framework/outcomes.py)
        click.echo(f"{failed} of {summary['runs']} runs not a success (status not in "
                   f"{list(plan.dispersions.success)}): exit status {SWEEP_RUN_FAILED}", err=True)
        sys.exit(SWEEP_RUN_FAILED)


@hookimpl
def snakesim_add_commands(cli):
    cli.add_command(sweep)
