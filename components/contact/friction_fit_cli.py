"""``snakesim fit-friction DATA.csv``: fit μ and ‖e_v‖ = a + b·F_n from drag tests (fig. 6).

``--out FILE`` writes a materials file that a terrain YAML includes as it is
(``materials: [{include: FILE}]``, snakesim.components.materials). The drag tests do not
measure the penalty k and c: they come from ``--k``/``--c``, else from ``--base`` (a
terrain's material), else the Material defaults; the file says which.

Registered through the ``snakesim_add_commands`` hook (see the hookimpl below).
"""

from __future__ import annotations

import re
from pathlib import Path

import click
from pydantic import ValidationError

from snakesim.components.materials import Material
from snakesim.framework import SnakesimError, hookimpl

from .friction_fit import fit_friction as _fit, format_fit, material_file, plot_fit, read_drag_tests


def _material_name(data_path: str) -> str:
    stem = Path(data_path).stem
    stem = re.sub(r"[-_]?drag[-_]?tests?$", "", stem) or stem
    return re.sub(r"\W+", "_", stem).strip("_") or "material"


def base_material(ref: str) -> tuple[Material, str]:
    """``TERRAIN`` or ``TERRAIN:MATERIAL`` -> (that material, how the file names it); default: the first."""
    from snakesim.components.terrain.spec import terrain_materials

    terrain, name = ref, None
    if not Path(ref).expanduser().is_file() and ":" in ref:
        terrain, _, name = ref.rpartition(":")
    mats = terrain_materials(terrain)
    if name is None:
        return mats[0], f"from material '{mats[0].name}' of terrain {terrain} (--base; its first material)"
    for m in mats:
        if m.name == name:
            return m, f"from material '{name}' of terrain {terrain} (--base)"
    raise SnakesimError(f"--base {ref}: terrain {terrain} has no material '{name}'; "
                        f"its materials: {', '.join(m.name for m in mats)}")


@click.command("fit-friction")
@click.argument("data", type=click.Path(dir_okay=False))
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False), help="Save the three-panel fit (PNG) here.")
@click.option("--out", "out_path", type=click.Path(dir_okay=False),
              help="Write a materials file here; a terrain YAML includes it: materials: [{include: FILE}].")
@click.option("--material", help="Material name in the file (default: from the data file name).")
@click.option("--k", "k", type=float, help="N/m, penalty stiffness written with the fit (drag tests do not measure it).")
@click.option("--c", "c", type=float, help="N·s/m, penalty damping written with the fit (not measured either).")
@click.option("--base", metavar="TERRAIN[:MATERIAL]",
              help="Take k and c (where --k/--c are not given) from this terrain's material "
                   "(a name in terrains/ or a YAML path; default: its first material).")
def fit_friction(data, plot_path, out_path, material, k, c, base):
    """Fit mu and ||e_v|| = ev_a + ev_b*F_n from screw drag tests in DATA (CSV with columns
    normal_force, direction [parallel|normal], drag_force; '#' lines are comments)."""
    try:
        tests = read_drag_tests(data)
        fit = _fit(tests)
        if base:
            ref, origin = base_material(base)
        else:
            ref, origin = Material(), ("snakesim's default Material value; choose it with --k/--c or "
                                       "--base TERRAIN[:MATERIAL]")
    except SnakesimError as e:
        raise click.ClickException(str(e)) from None
    click.echo(format_fit(fit, tests))
    name = material or _material_name(data)
    try:
        mat = fit.material(name, ref.k if k is None else k, ref.c if c is None else c)
    except ValidationError as e:
        msgs = "; ".join(err["msg"].removeprefix("Value error, ") for err in e.errors())
        raise click.ClickException(f"the fitted material cannot be written: {msgs}") from None
    text = material_file(mat, fit, data, "given with --k" if k is not None else origin,
                         "given with --c" if c is not None else origin,
                         Path(out_path).name if out_path else "FILE.yaml")
    if out_path:
        Path(out_path).parent.mkdir(parents=True, exist_ok=True)
        Path(out_path).write_text(text)
        click.echo(f"wrote {out_path} (include it from a terrain file: materials: [{{include: {Path(out_path).name}}}])")
    else:
        click.echo("\n" + text, nl=False)
    if plot_path:
        Path(plot_path).parent.mkdir(parents=True, exist_ok=True)
        plot_fit(fit, plot_path)
        click.echo(f"wrote {plot_path}")


@hookimpl
def snakesim_add_commands(cli):
    cli.add_command(fit_friction)
