"""``snakesim run --lidar PRESET --stereo WxH``: head sensors on any scene (see .attach).

Each sensor added is told on stderr in one line (:func:`.attach.sensor_notice`): name, resolution, rate,
frame, and where its data go (the sinks given on the same command line, the recorded ports) or that nothing
publishes them. ``snakesim check`` takes the same two options (``for_check``).
"""

from __future__ import annotations

import click

from snakesim.framework import hookimpl

from .beam_patterns import PRESETS


def _sinks_given() -> list[str]:
    """The sensor-taking run options (attach.SENSOR_SINK_OPTIONS) given on this command line: they are
    applied after the sensors (``adds_sink``), so the notice looks at the command's parameters."""
    from .attach import SENSOR_SINK_OPTIONS

    ctx = click.get_current_context(silent=True)
    params = ctx.params if ctx is not None else {}
    return [name for name in SENSOR_SINK_OPTIONS if params.get(name)]


def _tell(resolved, name: str) -> None:
    from .attach import sensor_notice

    click.echo(sensor_notice(resolved, name, _sinks_given()), err=True)


def _param(name: str):
    ctx = click.get_current_context(silent=True)
    return ctx.params.get(name) if ctx is not None else None


def _lidar(resolved, value):
    from .attach import LIDAR, attach_lidar

    attach_lidar(resolved, value, rate=_param("lidar_rate"))
    _tell(resolved, LIDAR)


def _stereo(resolved, value):
    from .attach import STEREO, attach_stereo

    attach_stereo(resolved, value, rate=_param("stereo_rate"))
    _tell(resolved, STEREO)


def _rate_of(sensor: str):
    """--lidar-rate / --stereo-rate: read by the sensor's own option (the order the options are applied
    in is not theirs); alone, a clear error."""
    def check(resolved, value):
        if value is not None and not _param(sensor):
            raise click.UsageError(f"--{sensor}-rate {value:g} needs --{sensor}: it sets that sensor's rate")
    check.for_check = True
    return check


# `snakesim check --lidar ... --stereo ...` builds what `run` would (framework/cli.py install_plugin_cli)
_lidar.for_check = _stereo.for_check = True


@hookimpl(specname="snakesim_run_options")
def perception_run_options():
    return [
        (click.Option(["--lidar"], type=click.Choice(sorted(PRESETS)), default=None,
                      help="Add a head lidar (10 Hz) of this preset on the robot's 'lidar' link"), _lidar),
        (click.Option(["--stereo"], default=None, metavar="WxH",
                      help="Add a 90° stereo pair (5 Hz, 6.75 cm baseline) of WxH pixels on 'camera_left'"), _stereo),
        (click.Option(["--lidar-rate"], type=click.FloatRange(min=0, min_open=True), default=None, metavar="HZ",
                      help="Rate of the --lidar sensor (default 10 Hz)"), _rate_of("lidar")),
        (click.Option(["--stereo-rate"], type=click.FloatRange(min=0, min_open=True), default=None, metavar="HZ",
                      help="Rate of the --stereo pair (default 5 Hz)"), _rate_of("stereo")),
    ]
