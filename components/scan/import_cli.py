"""``snakesim terrain import SCAN -o TERRAIN.yaml [options]``: a field scan becomes a mesh terrain
(import_scan.py), and its report is printed (docs/scan.md).

Options have no click defaults: an option left out takes :class:`ImportOptions`'s value, so there is one
place the defaults live. The terrain group registers this command (``terrain.add_command``).
"""

from __future__ import annotations

import shlex

import click

from snakesim.framework.cli_numbers import comma_floats


def _outliers(text: str):
    """(k, std), or None for 'none' (no outlier removal)."""
    if text.strip().lower() == "none":
        return None
    k, std = comma_floats(text, 2, "--outliers", "K,STD (neighbours, standard deviations) or 'none'")
    if k < 1 or k != int(k) or not std > 0:
        raise click.BadParameter(f"'{text}': K is a whole number >= 1 and STD > 0", param_hint="--outliers")
    return int(k), std


def _offset(text: str):
    if text.strip().lower() == "none":
        return "none"
    return comma_floats(text, 3, "--offset", "X,Y,Z (file units) or 'none'")


@click.command(name="import")
@click.argument("scan", type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", "output", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="The terrain .yaml to write; its mesh goes next to it as .ply.")
@click.option("--units", type=click.Choice(["m", "mm", "cm", "ft", "us-ft"]), default=None,
              help="The file's unit (default: a LAS file's own when metres, else m).")
@click.option("--up", type=click.Choice(["+z", "-z", "+y", "-y", "+x", "-x"]), default=None,
              help="The file's up axis, turned to +z (default +z).")
@click.option("--offset", default=None, metavar="X,Y,Z|none",
              help="Georeferenced offset subtracted, file units (default: a LAS header's, rounded).")
@click.option("--voxel", type=click.FloatRange(min=0, min_open=True), default=None, metavar="M",
              help="Voxel downsampling cell, m (default: none).")
@click.option("--outliers", default=None, metavar="K,STD|none",
              help="Statistical outlier removal: K neighbours, STD standard deviations (default 20,3).")
@click.option("--reconstruction", default=None, metavar="NAME",
              help="poisson (default) or ball_pivoting.")
@click.option("--depth", type=click.IntRange(min=1, max=12), default=None,
              help="Poisson octree depth (default: cells of about two point spacings).")
@click.option("--trim-quantile", type=click.FloatRange(min=0, max=1, max_open=True), default=None,
              help="Poisson: remove vertices below this density quantile (default 0.02).")
@click.option("--max-gap", type=click.FloatRange(min=0), default=None, metavar="M",
              help="Remove faces farther than this from any point, m (default: 5 spacings; 0: keep).")
@click.option("--faces", type=click.IntRange(min=0), default=None, metavar="N",
              help="Face budget of the decimation (default 100000; 0: no decimation).")
@click.option("--scanner-positions", type=click.Path(exists=True, dir_okay=False, path_type=str), default=None,
              metavar="FILE.csv", help="x,y,z rows (file frame): one for all points, or row i for LAS "
                                       "point_source_id i.")
@click.option("--resolution", type=click.FloatRange(min=0, min_open=True), default=None, metavar="M",
              help="SDF grid spacing of the terrain, m (default: 1/128 of the mesh's padded box).")
def import_command(scan, output, **given):
    """Import the scan SCAN (.ply .pcd .xyz .las .laz points; .ply .stl .obj meshes) as a mesh terrain
    OUTPUT, and print how well the mesh fits the scan: distances, coverage, holes."""
    from snakesim.framework.errors import SnakesimError

    from .import_scan import ImportOptions, import_scan

    values = {k: v for k, v in given.items() if v is not None}
    if "outliers" in values:
        values["outliers"] = _outliers(values["outliers"])
    if "offset" in values:
        values["offset"] = _offset(values["offset"])
    command = "snakesim terrain import " + " ".join(shlex.quote(a) for a in _argv(scan, output, given))
    try:
        result = import_scan(scan, output, ImportOptions(**values), command)
    except SnakesimError as e:
        raise click.ClickException(str(e)) from None
    for note in result.notes:
        click.echo(f"  {note}")
    for line in result.report.summary_lines():
        click.echo(line)
    click.echo(f"wrote {result.terrain} and {result.mesh}")
    click.echo(f"SDF grid {'computed into' if result.sdf_computed else 'already in'} the terrain store "
               f"{result.store}")


def _argv(scan, output, given) -> list[str]:
    """The command's arguments as the user gave them (what the provenance block records)."""
    args = [scan, "-o", output]
    for key, value in given.items():
        if value is not None:
            args += [f"--{key.replace('_', '-')}", str(value)]
    return args
