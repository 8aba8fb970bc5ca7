"""The viewer on the command line: ``snakesim run --viz TARGET`` and ``snakesim replay RUN_DIR``.

Registered through the ``snakesim_run_options`` and ``snakesim_add_commands``
hooks (hookimpls below, named with ``specname`` so they sit beside other
built-in hookimpls in components/plugin.py).
"""

from __future__ import annotations

from pathlib import Path

import click

from snakesim.framework import SnakesimError, hookimpl

from .target import USAGE, VizTarget, VizTargetError, parse_target

VIZ_HELP = (f"Show the run in rerun: {USAGE}. spawn opens a viewer (headless machines: saves "
            "snakesim.rrd instead), save writes FILE.rrd, serve streams to a web viewer.")


class TargetType(click.ParamType):
    name = "spawn|save FILE.rrd|serve"

    def convert(self, value, param, ctx):
        if isinstance(value, VizTarget):
            return value
        try:
            target = parse_target(value)
        except VizTargetError as e:
            self.fail(str(e), param, ctx)
        if target.mode == "save":     # checked before the run: a long run never ends unable to save
            from snakesim.framework.run_files import check_writable_file
            try:
                check_writable_file(target.path, "--viz save")
            except SnakesimError as e:
                self.fail(str(e), param, ctx)
        return target


class TargetOption(click.Option):
    """``--viz save FILE.rrd`` takes the file as the option's second word (the other
    modes take one word), so FILE.rrd is never read as the scene argument."""

    def add_to_parser(self, parser, ctx):
        super().add_to_parser(parser, ctx)
        for opt in self.opts:
            entry = getattr(parser, "_long_opt", {}).get(opt)
            if entry is None or not hasattr(entry, "process"):
                continue            # another click: `--viz save=FILE.rrd` still works
            process = entry.process

            def take_file(value, state, process=process):
                rargs = getattr(state, "rargs", None)
                if value == "save" and rargs and not rargs[0].startswith("-"):
                    value = f"save {rargs.pop(0)}"
                process(value, state)

            entry.process = take_file


def _apply(resolved, target: VizTarget) -> None:
    from .attach import attach_viewer

    attach_viewer(resolved, target)


_apply.adds_sink = True        # after options that add components: it shows what they add


@hookimpl(specname="snakesim_run_options")
def viz_run_options():
    return [(TargetOption(["--viz"], type=TargetType(), default=None, help=VIZ_HELP), _apply)]


@click.command("replay")
@click.argument("run_dir", type=click.Path(file_okay=False))
@click.option("--viz", "target", cls=TargetOption, type=TargetType(), default=None,
              help=f"{USAGE} (default: save RUN_DIR/replay.rrd).")
@click.option("--body-frames", is_flag=True, help="Draw every link frame (ornamental).")
def replay_command(run_dir, target, body_frames):
    """Turn a finished `snakesim run --out RUN_DIR` folder into a rerun recording
    (no re-simulation): robot geometry from config.yaml, link poses and every
    signal column from signals.csv."""
    from .replay import replay

    target = target or VizTarget("save", str(Path(run_dir) / "replay.rrd"))
    try:
        report = replay(run_dir, target, body_frames=body_frames)
    except SnakesimError as e:
        raise click.ClickException(str(e)) from None
    for line in report.notes:
        click.echo(f"note: {line}", err=True)
    click.echo(f"{report.target}: {report.frames} frames, {len(report.series)} signals"
               + (f" (view with `rerun {report.target.path}`)" if report.target.mode == "save" else ""), err=True)


@hookimpl(specname="snakesim_add_commands")
def viz_add_commands(cli):
    cli.add_command(replay_command)
