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
            "snakesim.rrd instead), save writes FILE.rrd, serve streams to a web viewer on this machine "
            "(see --viz-host, --viz-port) and keeps serving after the run until Ctrl-C.")


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


SERVE_OPTIONS = {"viz_host": "serve_host", "viz_port": "serve_port", "viz_grpc_port": "grpc_port"}


def _serve_params(target: VizTarget) -> dict:
    """The sink's serve_* params from --viz-host/--viz-port/--viz-grpc-port (read from the command's
    parameters: each option is applied on its own), their ports checked free before anything is built."""
    import dataclasses

    from snakesim.framework.errors import ConfigError

    from .target import check_serve_ports

    ctx = click.get_current_context(silent=True)
    given = {k: v for k, v in (ctx.params if ctx is not None else {}).items() if k in SERVE_OPTIONS and v is not None}
    if target.mode != "serve":
        if given:
            opts = ", ".join("--" + k.replace("_", "-") for k in given)
            raise ConfigError(f"{opts} only apply to --viz serve (this run has --viz {target})", "--viz")
        return {}
    params = {SERVE_OPTIONS[k]: v for k, v in given.items()}
    full = dataclasses.replace(target, host=params.get("serve_host", target.host),
                               port=params.get("serve_port", target.port),
                               grpc_port=params.get("grpc_port", target.grpc_port))
    try:
        check_serve_ports(full)             # before the build: a busy port is said at once, not mid-run
    except VizTargetError as e:
        raise SnakesimError(str(e)) from None
    return params


def _apply(resolved, target: VizTarget) -> None:
    from .attach import attach_viewer

    attach_viewer(resolved, target, params=_serve_params(target) or None)


_apply.adds_sink = True        # after options that add components: it shows what they add


def _serve_option(resolved, value):
    """Read by --viz's own apply (_serve_params); nothing to do alone, except without --viz."""
    ctx = click.get_current_context(silent=True)
    if ctx is not None and ctx.params.get("viz") is None:
        from snakesim.framework.errors import ConfigError

        raise ConfigError("--viz-host/--viz-port/--viz-grpc-port need --viz serve", "--viz")


@hookimpl(specname="snakesim_run_options")
def viz_run_options():
    return [(TargetOption(["--viz"], type=TargetType(), default=None, help=VIZ_HELP), _apply),
            (click.Option(["--viz-host"], default=None, metavar="HOST",
                          help="--viz serve: the address its servers listen on (default 127.0.0.1, this machine "
                               "only; 0.0.0.0 opens them to the network)"), _serve_option),
            (click.Option(["--viz-port"], type=click.IntRange(1, 65535), default=None, metavar="PORT",
                          help="--viz serve: the web viewer's port (default 9090)"), _serve_option),
            (click.Option(["--viz-grpc-port"], type=click.IntRange(1, 65535), default=None, metavar="PORT",
                          help="--viz serve: the recording's gRPC port, for `rerun --connect` (default 9876)"),
             _serve_option)]


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
