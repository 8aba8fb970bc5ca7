"""``snakesim run --ros2-mcap FILE``: the run's ROS 2 topics recorded to MCAP (:mod:`.mcap_recorder`);
``snakesim mcap recover FILE [-o OUT]``: a killed run's file rewritten readable (:mod:`.mcap_recover`).

``--ros2-mcap`` implies ``--ros2``; it is applied after the options that add components (``--lidar``,
``--stereo``), and the recorders mirror the publisher and the sensor bridge (params, rates, wiring), kept in
step when ``--ros2-rate`` or a later ``--ros2`` option changes them: what is on the wire is in the file, in
any order and combination of options.
"""

from __future__ import annotations

import click

from snakesim.framework import hookimpl


def _mcap(resolved, value):
    if value:
        from .mcap_recorder import attach_mcap

        attach_mcap(resolved, value)


# applied with the options that add sinks, after those that add components (--lidar, --stereo): the
# recording mirrors the sensor bridge those sensors bring
_mcap.adds_sink = True


@hookimpl(specname="snakesim_run_options")
def ros2_mcap_run_options():
    return [
        (click.Option(["--ros2-mcap"], default=None, metavar="FILE",
                      help="Record the ROS 2 topics to an MCAP file (ROS 2 schemas, CDR as published; the "
                           "sensors' topics too); implies --ros2. A killed run's file: snakesim mcap recover FILE."),
         _mcap),
    ]


@click.group(name="mcap")
def mcap():
    """MCAP recordings (snakesim run --ros2-mcap FILE)."""


@mcap.command(name="recover")
@click.argument("file", type=click.Path(dir_okay=True, path_type=str))
@click.option("-o", "--output", "output", default=None, type=click.Path(dir_okay=False, path_type=str),
              help="File to write (default: FILE's name with .recovered before its suffix, beside it).")
def recover_command(file, output):
    """Rewrite a readable MCAP file from FILE, one cut short (a killed run): every whole record up to where
    it ends, with a new summary and footer (as `ros2 bag reindex`). Prints the messages recovered per
    channel."""
    from .mcap_recover import RecoverError, recover

    try:
        result = recover(file, output)
    except RecoverError as e:
        raise click.ClickException(str(e)) from None
    except OSError as e:
        raise click.ClickException(f"{file}: {e.strerror or e}") from None
    click.echo(result.summary())
