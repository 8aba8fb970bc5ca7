"""The ``snakesim`` command line (click), in the spirit of the paper's Dclick.

Options have no click defaults: an option left out never hides a value from a
config file. Precedence, later wins: Params defaults < assembly < each
``--config`` file < each ``--set`` < explicit flags (``--dt``, ``--duration``,
``--integrator``, ``--realtime``).
"""

from __future__ import annotations

import importlib
import json
import signal
import sys
from pathlib import Path

import click

from .errors import SnakesimError
from .outcomes import exit_codes_help, run_exit_code
from .run_reports import report_lines

# registry, assembly and session load inside the commands: `snakesim --help` must not pay for
# numpy, pydantic and every component (bench/cli_startup.py measures it)


def default_registry():
    from .registry import default_registry as registry

    return registry()


def _fail(e: Exception):
    raise click.ClickException(str(e))


def _progress(stream=None):
    return _ProgressLine(stream)


class _ProgressLine:
    """The progress line, redrawn in place on stderr (called with t, t_end). While it is in use (``with``),
    anything else written to stderr (a Python warning, a log record, a component's message) starts on a line
    of its own: the progress line is cleared first and drawn again at the next report."""

    def __init__(self, stream=None):
        self.stream, self.shown, self._under = stream, 0, None

    def _out(self):
        # looked up per call: stderr may be redirected after import; inside ``with``, the stream under the guard
        return self.stream or self._under or sys.stderr

    def __call__(self, t, t_end):
        frac = min(1.0, t / t_end) if t_end else 1.0
        bar = "#" * int(30 * frac)
        text = f"  [{bar:<30}] {100 * frac:5.1f}%  t = {t:.2f} / {t_end:.2f} s"
        out = self._out()
        out.write("\r" + text)
        out.flush()
        self.shown = len(text)

    def clear(self):
        if self.shown:
            out = self._out()
            out.write("\r" + " " * self.shown + "\r")
            out.flush()
            self.shown = 0

    def __enter__(self):
        self._under = sys.stderr
        sys.stderr = _LineGuard(self, self._under)
        return self

    def __exit__(self, *exc):
        if isinstance(sys.stderr, _LineGuard) and sys.stderr.progress is self:
            sys.stderr = self._under
        self._under = None
        return False


class _LineGuard:
    """stderr while a progress line is shown: clears the line before any other text is written."""

    def __init__(self, progress: _ProgressLine, stream):
        self.progress, self.stream = progress, stream

    def write(self, text):
        if text and self.progress.shown:
            self.progress.clear()
        return self.stream.write(text)

    def __getattr__(self, name):
        return getattr(self.stream, name)


def _session(assembly, config, sets, extras=None, **sim):
    """Resolve, let plugin run options edit the configuration, build."""
    from .assembly import resolve
    from .session import Session

    reg = default_registry()
    extras = {k: v for k, v in (extras or {}).items() if v is not None}
    # shorthand options (--robot, --modules, ...) are --set items, placed before the explicit ones
    sets = [f"{_SHORTHANDS[k]}={v}" for k, v in extras.items() if k in _SHORTHANDS] + list(sets)
    if assembly is None:
        assembly = reg.default_assembly()
    resolved = resolve(assembly, search_path=reg.assembly_paths(), config_files=config, overrides=sets,
                       sim_overrides=sim)
    # options that add components first, then those that add sinks (which wire what they find)
    chosen = [(_RUN_OPTIONS[n], v) for n, v in extras.items() if n in _RUN_OPTIONS]
    for apply, value in sorted(chosen, key=lambda c: bool(getattr(c[0], "adds_sink", False))):
        apply(resolved, value)
    return Session(resolved, reg)


def _positive(ctx, param, value):
    if value is not None and value <= 0:
        raise click.BadParameter(f"must be > 0, got {value:g}")
    return value


def scene_options(f):
    f = click.option("--set", "sets", multiple=True, metavar="KEY.PATH=VALUE",
                     help="Deep override, e.g. components.pend.params.length=2 or a parameter: damping=0.1.")(f)
    f = click.option("--config", "config", multiple=True, type=click.Path(dir_okay=False),
                     help="Config file merged over the assembly (repeatable; later wins).")(f)
    return f


class LazyCommand(click.Command):
    """A plugin command known by name and one line until it runs: its module (and whatever that module
    imports) loads only when the command is looked up to run or to show its own help."""

    def __init__(self, name: str, target: str, short_help: str):
        super().__init__(name, short_help=short_help)
        self.target = target

    def load(self) -> click.Command:
        module, attr = self.target.split(":")
        return getattr(importlib.import_module(module), attr)


def lazy_command(name: str, target: str, short_help: str) -> LazyCommand:
    """For ``snakesim_add_commands``: ``cli.add_command(lazy_command("replay", "pkg.mod:replay", "..."))``."""
    return LazyCommand(name, target, short_help)


class _SnakesimGroup(click.Group):
    """Installs plugin commands before listing them and plugin options before running one."""

    def list_commands(self, ctx):
        _install_commands()
        return super().list_commands(ctx)

    def get_command(self, ctx, name):
        if name in _TAKE_PLUGIN_OPTIONS:
            install_plugin_cli()
        else:
            _install_commands()
        cmd = self.commands.get(name)
        if isinstance(cmd, LazyCommand):
            cmd = self.commands[name] = cmd.load()
        return cmd

    def format_commands(self, ctx, formatter):
        # the one-line help of every command, lazy ones unloaded (click's own would load them all)
        _install_commands()
        limit = formatter.width - 6 - max((len(n) for n in self.commands), default=0)
        rows = [(n, c.get_short_help_str(limit)) for n, c in sorted(self.commands.items()) if not c.hidden]
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


@click.group(cls=_SnakesimGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="snakesim", prog_name="snakesim", message="%(prog)s %(version)s")
def cli():
    """snakesim: a dataflow simulator for snake robots (and anything else built from components)."""


@cli.command()
@click.argument("assembly", required=False)
@scene_options
@click.option("--duration", type=float, callback=_positive, help="Simulated time, s.")
@click.option("--dt", type=float, callback=_positive, help="Base step, s.")
@click.option("--integrator", help="semi_implicit_euler, rk4, dopri5, rosenbrock2, rosenbrock_w or a plugin's.")
@click.option("--realtime/--no-realtime", default=None, help="Pace simulated time to the wall clock.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False),
              help="Write signals.csv, summary.json, config.yaml here (a new or empty folder; see --overwrite).")
@click.option("--overwrite", is_flag=True, default=None,
              help="Let --out name a folder that holds files already: the run's files in it are replaced.")
@click.option("--save-config", type=click.Path(dir_okay=False), help="Write the full resolved configuration here.")
@click.option("--quiet", is_flag=True, help="No progress or summary on the terminal.")
def run(assembly, config, sets, duration, dt, integrator, realtime, out_dir, overwrite, save_config, quiet,
        **shorthands):
    """Run ASSEMBLY (a YAML path or a scene name; default: the default scene).

    Exits 0 when the run succeeds (its duration reached, or a stop declared a success) and with one
    code per kind of failure otherwise (summary.json: outcome, failure_kind): EXIT_CODES. Ctrl-C or
    SIGTERM ends the run at the next step and still writes --out (the summary says it was interrupted,
    and when), exit 128 + signal; a second one stops at once."""
    from .run_files import check_writable_file, prepare_out_dir, release_out_dir
    from .warm_up import FIRST_COMPILE_S, kernels_cached

    with _Interrupts() as interrupts:
        try:
            # where the run writes is checked before anything is built or run
            if out_dir:
                prepare_out_dir(out_dir, overwrite=bool(overwrite))
            if save_config:
                check_writable_file(save_config, "--save-config")
            if not quiet and not kernels_cached():
                click.echo(f"compiling kernels, once: about {FIRST_COMPILE_S} s (numba caches them for every later "
                           "run; the run's clock starts after)", err=True)
            s = _session(assembly, config, sets, shorthands, duration=duration, dt=dt, integrator=integrator,
                         realtime=realtime)
            interrupts.attach(s)
            if save_config:
                try:
                    Path(save_config).write_text(s.config_text())
                except OSError as e:
                    raise SnakesimError(f"--save-config {save_config}: cannot write there ({e.strerror or e})") from None
            if not quiet:
                click.echo(f"running {s.resolved.source}: {s.resolved.sim.duration:g} s at dt = {s.resolved.sim.dt:g} s "
                           f"with {s.integrator.name}", err=True)
            _print_estimate(s, out_dir, quiet)
            if quiet:
                result = s.run(out_dir=out_dir, progress=None)
            else:
                with _progress() as progress:       # warnings during the run start on a line of their own
                    result = s.run(out_dir=out_dir, progress=progress)
        except SnakesimError as e:
            _fail(e)
        except KeyboardInterrupt:       # a second Ctrl-C: stop at once
            click.echo(f"\ninterrupted twice: stopped at once{'' if not out_dir else f'; {out_dir} may be incomplete'}",
                       err=True)
            sys.exit(130)
        finally:
            if out_dir:
                release_out_dir(out_dir)     # this process's claim of the folder (run_files.py), if it holds one
    sm = result.summary
    code = run_exit_code(sm)        # 0, a failure kind's code (framework/outcomes.py) or 128 + signal
    if not quiet:
        click.echo(f"\r{' ' * 70}\r{sm['stop_reason']}: {sm['sim_time_s']:.4g} s simulated in {sm['wall_time_s']:.3g} s "
                   f"({sm['real_time_factor']:.3g}x real time, {sm['steps']} steps)", err=True)
        for line in report_lines(s.plan, sm):     # components' end-of-run reports (framework/run_reports.py)
            click.echo(line, err=True)
        if out_dir:
            extra = ", last_good_state.npz" if result.last_good_state is not None else ""
            click.echo(f"wrote {out_dir}/signals.csv, summary.json, config.yaml{extra}", err=True)
    if not out_dir and (result.last_good_state is not None or "interrupted" in sm):
        # said even with --quiet: the run did not complete and nothing of it is kept
        what = "the signals so far and the last good state" if result.last_good_state is not None else "the signals so far"
        click.echo(f"{sm['stop_reason']}: nothing was saved (no --out); run again with --out DIR to keep {what}, "
                   "a summary and the config", err=True)
    if code:
        if "interrupted" not in sm:
            # said even with --quiet (its only line then, with the reason): a failed run is never silent
            reason = f"{sm['stop_reason']}: " if quiet else ""
            click.echo(f"{reason}failure ({sm['failure_kind']}): exit status {code}", err=True)
        sys.exit(code)


run.help = run.help.replace("EXIT_CODES", exit_codes_help())      # the one table: framework/outcomes.py


#: a run of at least this many base steps, or whose recording takes at least this share of the memory
#: limit, is told its size before it starts
LONG_RUN_STEPS, LARGE_RECORDING_SHARE = 10**6, 0.1


def _print_estimate(s, out_dir, quiet: bool) -> None:
    """Before a long or large run starts: its steps, its recording's size in memory (and on disk with
    --out) against the memory limit; a recording that cannot fit is warned about, even with --quiet,
    with the record rate that fits (framework/recorder.py). Nothing is refused here that can run: the
    recorder stops such a run at the limit, keeping its rows."""
    from .limits import fmt_bytes
    from .recorder import recording_estimate, recording_warning

    duration = s.resolved.sim.duration
    est = recording_estimate(s.plan, duration)
    warning = recording_warning(est, duration)
    if not quiet and (est["steps"] >= LONG_RUN_STEPS or est["bytes"] >= LARGE_RECORDING_SHARE * est["limit"]):
        disk = f", ~{fmt_bytes(est['csv_bytes'])} of signals.csv in {out_dir}" if out_dir else ""
        click.echo(f"estimate: {est['steps']:.4g} base steps (the wall time shows as the progress line's ETA once "
                   f"it runs); the recording {est['rows']:.4g} rows x {est['columns']} signal columns at "
                   f"sim.record_rate = {est['record_rate']:.4g} Hz, ~{fmt_bytes(est['bytes'])} in memory (limit "
                   f"{fmt_bytes(est['limit'])}){disk}", err=True)
    if warning:
        click.echo(f"warning: {warning}", err=True)


class _Interrupts:
    """SIGINT and SIGTERM during ``run``: the first ends the run at the next step boundary (before the run
    starts: at its first step, once the build is done), so the run is written; a second one gets the
    signal's default action (Ctrl-C: stop at once). Signals the caller ignores stay ignored."""

    def __init__(self):
        self.session, self.signal, self.old = None, None, {}

    def __enter__(self):
        for sig in (signal.SIGINT, signal.SIGTERM):
            try:
                if signal.getsignal(sig) is not signal.SIG_IGN:
                    self.old[sig] = signal.signal(sig, self._handle)
            except ValueError:      # not the main thread (an embedding caller): no handlers
                pass
        return self

    def _handle(self, signum, frame):
        self._restore()
        self.signal = signal.Signals(signum).name
        if self.session is not None:
            self.session.interrupt(self.signal)
        else:
            sys.stderr.write(f"\n{self.signal}: the run will stop at its first step, once the build is done "
                             "(send it again to stop at once)\n")

    def attach(self, session) -> None:
        self.session = session
        if self.signal is not None:
            session.interrupt(self.signal)

    def _restore(self):
        for sig, old in self.old.items():
            signal.signal(sig, old)
        self.old = {}

    def __exit__(self, *exc):
        self._restore()
        return False


@cli.command()
@click.argument("assembly", required=False)
@scene_options
@click.option("--json", "as_json", is_flag=True, help="Machine-readable report.")
@click.option("--baseline", is_flag=True,
              help="Also build and time the unoptimised baselines (the multibody optimisation's cost; "
                   "at 100 modules about a GB and seconds).")
def check(assembly, config, sets, as_json, baseline, **shorthands):
    """Build ASSEMBLY and report it without running."""
    try:
        s = _session(assembly, config, sets, shorthands)
    except SnakesimError as e:
        _fail(e)
    r = s.report(detail=True, baseline=baseline)
    if as_json:
        click.echo(json.dumps(r, indent=2, default=str))
        return
    click.echo(f"{r['source']}: {len(r['components'])} components, {r['connections']} connections")
    for n, c in r["components"].items():
        rate = f"{c['rate_hz']:g} Hz" if c["rate_hz"] else "continuous"
        click.echo(f"  {n:<28} {c['type']:<22} {rate:<12} x={c['continuous_states']} xd={c['discrete_states']}")
    click.echo(f"pruned (outputs reach no state, recorder or sink): {', '.join(r['pruned']) or 'none'}")
    users: dict[str, list[str]] = {}
    for n, slots in r.get("resources", {}).items():
        for slot, provider in slots.items():
            users.setdefault(f"{provider}.{slot}", []).append(n)
    for res, names in users.items():
        click.echo(f"resource {res} used by: {', '.join(names)}")
    st = r["state_size"]
    click.echo(f"state: {st['continuous']} continuous ({st['tangent']} tangent), {st['discrete']} discrete; "
               f"dt = {r['dt']:g} s, integrator {r['integrator']}")
    click.echo("evaluation order: " + " -> ".join(r["evaluation_order"]))
    for name, rep in r.get("component_reports", {}).items():
        click.echo(f"\n{name}:\n{rep}")


@cli.command()
@click.option("--json", "as_json", is_flag=True)
@click.option("--markdown", is_flag=True, help="The component reference as Markdown (docs/components.md).")
def components(as_json, markdown):
    """List every registered component with its ports, units and params."""
    from .reference import component_reference, reference_markdown

    ref = component_reference(default_registry())
    if as_json:
        click.echo(json.dumps(ref, indent=2))
    elif markdown:
        click.echo(reference_markdown(ref), nl=False)
    else:
        for name, c in ref.items():
            click.echo(f"{name}  ({c['class']}, from {c['module']})")
            for p in c["inputs"]:
                click.echo(f"    in   {p['name']:<14} {p['signal']}{'' if p['required'] else '  (optional)'}")
            for p in c["outputs"]:
                click.echo(f"    out  {p['name']:<14} {p['signal']}  feedthrough: {p['feedthrough'] or 'none'}")
            for p in c["params"]:
                click.echo(f"    par  {p['name']:<14} = {p['default']!r}  {p['type']}")


@cli.command()
@click.option("--markdown", is_flag=True, help="The scene catalogue as Markdown (docs/scenes.md).")
def scenes(markdown):
    """List every scene with the first sentence of its description."""
    from .scene_catalogue import first_sentence, scene_entries, scenes_markdown

    reg = default_registry()
    entries = scene_entries(reg.assembly_paths(), reg.default_assembly())
    if markdown:
        click.echo(scenes_markdown(entries), nl=False)
        return
    width = max((len(e["name"]) for e in entries), default=0)
    for e in entries:
        click.echo(f"{e['name']:<{width}}  {'(default) ' if e['default'] else ''}{first_sentence(e['description'])}")


@cli.command()
@click.argument("assembly", required=False)
@scene_options
@click.option("-o", "--output", "output", required=True, type=click.Path(dir_okay=False),
              help="Picture file: .svg or .png.")
def graph(assembly, config, sets, output, **shorthands):
    """Draw ASSEMBLY's dataflow graph as an SVG or PNG picture."""
    from .dataflow_picture import draw

    if Path(output).suffix.lower() not in (".svg", ".png"):
        raise click.BadParameter(f"'{output}': the picture must end in .svg or .png", param_hint="-o")
    try:
        s = _session(assembly, config, sets, shorthands)
        Path(output).parent.mkdir(parents=True, exist_ok=True)   # -o runs/x.svg: no need to make runs/ first
        draw(s, Path(output))
    except SnakesimError as e:
        _fail(e)
    click.echo(f"wrote {Path(output).resolve()}", err=True)   # where, whatever folder it ran from


_TAKE_PLUGIN_OPTIONS = ("run", "check", "graph")   # commands plugins add options to
_SHORTHANDS: dict[str, str] = {}   # option name -> --set key
_RUN_OPTIONS: dict[str, object] = {}  # option name -> apply(resolved, value)


def _plugin_manager():
    from .registry import make_plugin_manager

    return make_plugin_manager()


def _install_commands(pm=None) -> None:
    """Plugins' commands only (what the top-level help lists), once."""
    if getattr(cli, "_commands_installed", False) or getattr(cli, "_plugins_installed", False):
        return
    (pm or _plugin_manager()).hook.snakesim_add_commands(cli=cli)
    cli._commands_installed = True


def install_plugin_cli(registry=None) -> click.Group:
    """Add plugins' commands and shorthand options (``--robot`` -> ``--set robot.name``) once."""
    if getattr(cli, "_plugins_installed", False):
        return cli
    reg = registry or default_registry()
    if not getattr(cli, "_commands_installed", False):
        reg.pm.hook.snakesim_add_commands(cli=cli)
    for group in reg.pm.hook.snakesim_cli_shorthands():
        for option, key, help_text in group:
            name = option.lstrip("-").replace("-", "_")
            _SHORTHANDS[name] = key
            for cmd in (run, check, graph):
                if any(p.name == name for p in cmd.params):
                    continue
                cmd.params.append(click.Option([option, name], default=None, help=f"{help_text} (= --set {key}=…)"))
    for group in reg.pm.hook.snakesim_run_options():
        for option, apply in group:
            _RUN_OPTIONS[option.name] = apply
            if not any(p.name == option.name for p in run.params):
                run.params.append(option)
            # options that only add components (apply.for_check: --lidar, --stereo) build the same in check
            if getattr(apply, "for_check", False) and not any(p.name == option.name for p in check.params):
                check.params.append(option)
    cli._plugins_installed = True
    return cli


def main():
    from .blas_threads import pin_blas_threads
    pin_blas_threads()      # one BLAS thread unless SNAKESIM_BLAS_THREADS says otherwise: before numpy loads
    # plugins install on demand (_SnakesimGroup): the top-level help loads only their commands' names
    cli(prog_name="snakesim")
