"""``snakesim run --ros2-mcap FILE``: the run's ROS 2 topics recorded to MCAP (:mod:`.mcap_recorder`).

Implies ``--ros2``; the recorder mirrors the publisher (params, rates, wiring) at the moment the option is
applied, so give ``--ros2-rate`` before ``--ros2-mcap`` on the command line (or see ``sync_recorder``).
"""

from __future__ import annotations

import click

from snakesim.framework import hookimpl


def _mcap(resolved, value):
    if value:
        from .mcap_recorder import attach_mcap

        attach_mcap(resolved, value)


@hookimpl(specname="snakesim_run_options")
def ros2_mcap_run_options():
    return [
        (click.Option(["--ros2-mcap"], default=None, metavar="FILE",
                      help="Record the ROS 2 topics to an MCAP file (ROS 2 schemas, CDR as published); "
                           "implies --ros2."), _mcap),
    ]
