"""``snakesim terrain sdf NAME -o FILE.npz --resolution M [--bounds ...]``: a terrain's signed distance on a
regular grid, the ground truth a TSDF/ESDF mapper (voxblox, nvblox) is scored against.

The volume is :func:`snakesim.components.sensors.terrain_map.export_sdf_volume`'s (format:
``SDF_VOLUME_FORMAT``, read back with ``load_sdf_volume``), written whole or not at all
(framework/output_files.py). ``--bounds`` defaults to the terrain's own box when it is finite on every axis
(an obstacle field's ground is not: its x and y are unbounded), padded by one cell.
"""

from __future__ import annotations

import click

from snakesim.framework.cli_numbers import comma_floats


def _bounds(text: str | None):
    if text is None:
        return None
    v = comma_floats(text, 6, "--bounds", "six numbers XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX (m)")
    return list(v[:3]), list(v[3:])


@click.group(name="terrain")
def terrain():
    """Terrains (a name in terrains/ or a YAML/mesh path)."""


@terrain.command(name="sdf")
@click.argument("name")
@click.option("-o", "--output", "output", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="The .npz file to write.")
@click.option("--resolution", type=click.FloatRange(min=0, min_open=True), default=0.05, show_default=True,
              metavar="M", help="Grid spacing, m.")
@click.option("--bounds", default=None, metavar="XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX",
              help="The box sampled, m (default: the terrain's own box, when finite).")
def sdf_command(name, output, resolution, bounds):
    """Write NAME's signed distance (m, > 0 in free space) on a grid to OUTPUT (.npz: distance[nx, ny, nz],
    origin, resolution, terrain, format)."""
    import numpy as np

    from snakesim.components.sensors.terrain_map import export_sdf_volume, sdf_grid
    from snakesim.components.terrain.spec import load_terrain
    from snakesim.framework.errors import SnakesimError

    box = _bounds(bounds)
    try:
        t = load_terrain(name)
    except (SnakesimError, OSError, ValueError, KeyError) as e:
        raise click.ClickException(f"terrain '{name}': {e}") from None
    if box is None:
        b = t.bounds()
        open_axes = [a for a, lo, hi in zip("xyz", b.lo, b.hi) if not (np.isfinite(lo) and np.isfinite(hi))]
        if open_axes:
            raise click.UsageError(f"terrain '{name}' is unbounded along {', '.join(open_axes)}: give "
                                   "--bounds XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX")
        box = (b.lo - resolution, b.hi + resolution)
    try:
        origin, shape = sdf_grid(box, resolution)
    except ValueError as e:
        raise click.UsageError(str(e)) from None
    try:
        export_sdf_volume(t, box, resolution, output)
    except SnakesimError as e:
        raise click.ClickException(str(e)) from None
    click.echo(f"wrote {output}: {' x '.join(map(str, shape))} points at {resolution:g} m from "
               f"{np.round(origin, 6).tolist()} ({t.name})", err=True)


def _register_scan_commands():
    # the field-scan commands live with the scan package (components/scan/); their modules import Open3D and
    # laspy lazily, so `snakesim --help` stays quick without the [scan] extra
    from snakesim.components.scan.import_cli import import_command
    from snakesim.components.scan.synthetic_cli import scan_command

    terrain.add_command(import_command)
    terrain.add_command(scan_command)


_register_scan_commands()
