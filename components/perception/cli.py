"""``snakesim run --lidar PRESET --stereo WxH``: head sensors on any scene (see .attach)."""

from __future__ import annotations

import click

from snakesim.framework import hookimpl

from .beam_patterns import PRESETS


def _lidar(resolved, value):
    from .attach import attach_lidar

    attach_lidar(resolved, value)


def _stereo(resolved, value):
    from .attach import attach_stereo

    attach_stereo(resolved, value)


@hookimpl(specname="snakesim_run_options")
def perception_run_options():
    return [
        (click.Option(["--lidar"], type=click.Choice(sorted(PRESETS)), default=None,
                      help="Add a head lidar (10 Hz) of this preset on the robot's 'lidar' link"), _lidar),
        (click.Option(["--stereo"], default=None, metavar="WxH",
                      help="Add a 90° stereo pair (5 Hz, 6.75 cm baseline) of WxH pixels on 'camera_left'"), _stereo),
    ]
