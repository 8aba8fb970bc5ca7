"""Comma-separated numbers given to one command-line option (``--rope 1.2,0``, ``--bounds X0,Y0,Z0,X1,Y1,Z1``):
one parser, so every such option says the same thing when it is given something else."""

from __future__ import annotations

import click


def comma_floats(text: str, count: int, option: str, meaning: str) -> tuple[float, ...]:
    """``count`` floats from ``text`` (``"a,b,c"``); anything else is a :class:`click.BadParameter` naming
    ``option``, the text given and ``meaning`` (what the numbers are, with their units)."""
    try:
        v = tuple(float(a) for a in text.split(","))
    except ValueError:
        v = ()
    if len(v) != count:
        raise click.BadParameter(f"'{text}': expected {meaning}", param_hint=option)
    return v
