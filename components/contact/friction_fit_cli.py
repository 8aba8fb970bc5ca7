"""``snakesim fit-friction DATA.csv``: fit μ and ‖e_v‖ = a + b·F_n from drag tests (fig. 6).

Registered through the ``snakesim_add_commands`` hook (see the hookimpl below).
"""

from __future__ import annotations

import re
from pathlib import Path

import click

from snakesim.framework import SnakesimError, hookimpl

from .friction_fit import fit_friction as _fit, format_fit, material_yaml, plot_fit, read_drag_tests


def _material_name(data_path: str) -> str:
    stem = Path(data_path).stem
    stem = re.sub(r"[-_]?drag[-_]?tests?$", "", stem) or stem
    return re.sub(r"\W+", "_", stem).strip("_") or "material"


@click.command("fit-friction")
@click.argument("data", type=click.Path(dir_okay=False))
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False), help="Save the three-panel fit (PNG) here.")
@click.option("--out", "out_path", type=click.Path(dir_okay=False), help="Write a `materials:` YAML snippet here.")
@click.option("--material", help="Material name in the snippet (default: from the file name).")
def fit_friction(data, plot_path, out_path, material):
    """Fit mu and ||e_v|| = ev_a + ev_b*F_n from screw drag tests in DATA (CSV with columns
    normal_force, direction [parallel|normal], drag_force; '#' lines are comments)."""
    try:
        tests = read_drag_tests(data)
        fit = _fit(tests)
    except SnakesimError as e:
        raise click.ClickException(str(e)) from None
    click.echo(format_fit(fit, tests))
    name = material or _material_name(data)
    snippet = material_yaml(fit, name, data)
    if out_path:
        Path(out_path).write_text(snippet)
        click.echo(f"wrote {out_path}")
    else:
        click.echo("\n" + snippet, nl=False)
    if plot_path:
        plot_fit(fit, plot_path)
        click.echo(f"wrote {plot_path}")


@hookimpl
def snakesim_add_commands(cli):
    cli.add_command(fit_friction)
