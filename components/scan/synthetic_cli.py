"""``snakesim terrain scan TERRAIN -o SCAN.(las|laz|ply) [...]``: a synthetic field scan of any terrain.

A scanner lowered on a rope from ``--top`` to ``--bottom`` (``--poses`` stops on the vertical through ``--rope``),
its head turning a full circle at each stop, cast against the terrain with the sensors' ray caster, with range
noise, random and grazing dropouts, masked patches and, optionally, thinning to a voxel: .synthetic has the
model, .scan_files the formats. Writes SCAN and ``<SCAN>.poses.csv``; prints what was kept and lost. Bad values
are errors naming the option (a rope in the ice: the stop whose signed distance is not positive).
"""

from __future__ import annotations

import click

from snakesim.framework.cli_numbers import comma_floats

from .scan_files import SCAN_SUFFIXES


@click.command(name="scan")
@click.argument("terrain_name", metavar="TERRAIN")
@click.option("-o", "--output", "output", required=True, type=click.Path(dir_okay=False, path_type=str),
              help=f"The scan to write ({', '.join(SCAN_SUFFIXES)}); <SCAN>.poses.csv is written beside it.")
@click.option("--poses", type=int, default=15, show_default=True, help="Stops down the rope (>= 1).")
@click.option("--top", type=float, default=-0.5, show_default=True, metavar="Z", help="Highest stop, m.")
@click.option("--bottom", type=float, default=-7.5, show_default=True, metavar="Z", help="Lowest stop, m.")
@click.option("--rope", default="0,0", show_default=True, metavar="X,Y", help="Where the rope hangs, m.")
@click.option("--pattern", type=click.Choice(["spin", "tilted"]), default="spin", show_default=True,
              help="spin: one head, vertical axis; tilted: three heads at -35, 0, +35 deg about the head's x.")
@click.option("--channels", type=int, default=96, show_default=True, help="Elevations of a head.")
@click.option("--columns", type=int, default=1024, show_default=True, help="Azimuths of a head's turn.")
@click.option("--vfov", default="-70,70", show_default=True, metavar="LO,HI", help="Elevations, deg.")
@click.option("--range-noise", type=float, default=0.003, show_default=True, metavar="M",
              help="Range noise's standard deviation at zero range, m.")
@click.option("--range-noise-slope", type=float, default=0.0, show_default=True,
              help="Its growth with range (σ = range_noise + slope·r).")
@click.option("--dropout", type=float, default=0.01, show_default=True, metavar="P",
              help="Probability that a return is lost, in [0, 1).")
@click.option("--grazing", type=float, default=90.0, show_default=True, metavar="DEG",
              help="Returns at a larger incidence angle are lost, (0, 90] deg.")
@click.option("--mask", "masks", multiple=True, metavar="X,Y,Z,R",
              help="A sphere (m) inside which the wall returns nothing (a wet dark patch); repeatable.")
@click.option("--thin", type=float, default=0.0, show_default=True, metavar="M",
              help="Keep one return per voxel of this edge, m (0: every return).")
@click.option("--min-range", type=float, default=0.1, show_default=True, metavar="M")
@click.option("--max-range", type=float, default=10.0, show_default=True, metavar="M")
@click.option("--seed", type=int, default=0, show_default=True)
def scan_command(terrain_name, output, poses, top, bottom, rope, pattern, channels, columns, vfov, range_noise,
                 range_noise_slope, dropout, grazing, masks, thin, min_range, max_range, seed):
    """Write a synthetic scan of TERRAIN (a name in terrains/ or a path) to OUTPUT: points in metres, each with
    the scanner position it was measured from (module docstring of snakesim.components.scan.synthetic)."""
    from pathlib import Path

    from snakesim.components.terrain.spec import load_terrain
    from snakesim.framework.errors import SnakesimError

    from .scan_files import poses_path, write_las, write_ply_points, write_poses_csv
    from .synthetic import TILTED, ScanPattern, ScanSettings, check_rope, scan_terrain

    suffix = Path(output).suffix.lower()
    if suffix not in SCAN_SUFFIXES:
        raise click.BadParameter(f"'{output}': unknown suffix '{suffix}'; valid: {', '.join(SCAN_SUFFIXES)}",
                                 param_hint="--output")
    checks = [(poses >= 1, "--poses", f"{poses}: at least 1"),
              (range_noise >= 0, "--range-noise", f"{range_noise:g} m: must be >= 0"),
              (range_noise_slope >= 0, "--range-noise-slope", f"{range_noise_slope:g}: must be >= 0"),
              (0 <= dropout < 1, "--dropout", f"{dropout:g}: a probability in [0, 1)"),
              (0 < grazing <= 90, "--grazing", f"{grazing:g} deg: in (0, 90]"),
              (thin >= 0, "--thin", f"{thin:g} m: a voxel edge >= 0 (0: keep every return)"),
              (channels >= 1, "--channels", f"{channels}: at least 1"),
              (columns >= 1, "--columns", f"{columns}: at least 1"),
              (0 <= min_range < max_range, "--min-range/--max-range",
               f"{min_range:g}, {max_range:g} m: need 0 <= min-range < max-range"),
              (seed >= 0, "--seed", f"{seed}: must be >= 0")]
    for ok, option, why in checks:
        if not ok:
            raise click.BadParameter(why, param_hint=option)
    if top < bottom:
        raise click.BadParameter(f"--top {top:g} m is below --bottom {bottom:g} m: the rope is lowered from top "
                                 "to bottom (top >= bottom)", param_hint="--top/--bottom")
    lo, hi = comma_floats(vfov, 2, "--vfov", "2 numbers LO,HI (deg)")
    if not -90 <= lo <= hi <= 90:
        raise click.BadParameter(f"'{vfov}': need -90 <= LO <= HI <= 90 deg", param_hint="--vfov")
    spheres = tuple(comma_floats(m, 4, "--mask", "4 numbers X,Y,Z,R (m)") for m in masks)
    for m in spheres:
        if not m[3] > 0:
            raise click.BadParameter(f"'{','.join(f'{v:g}' for v in m)}': the radius R must be > 0 m",
                                     param_hint="--mask")
    head = ScanPattern(channels, columns, (lo, hi), TILTED if pattern == "tilted" else (0.0,))
    xy = comma_floats(rope, 2, "--rope", "2 numbers X,Y (m)")
    settings = ScanSettings(top=top, bottom=bottom, poses=poses, rope=xy,
                            pattern=head, min_range=min_range, max_range=max_range, range_noise=range_noise,
                            range_noise_slope=range_noise_slope, dropout=dropout, grazing=grazing, masks=spheres,
                            thin=thin, seed=seed)
    try:
        terrain = load_terrain(terrain_name)
    except (SnakesimError, OSError, ValueError, KeyError) as e:
        raise click.ClickException(f"terrain '{terrain_name}': {e}") from None
    try:
        check_rope(terrain, settings)
    except ValueError as e:
        raise click.BadParameter(str(e), param_hint="--rope") from None
    scan = scan_terrain(terrain, settings)
    if not len(scan):
        raise click.ClickException(f"no return from TERRAIN '{terrain_name}' within --max-range {max_range:g} m "
                                   f"of the rope: nothing to write ({scan.counts})")
    try:
        if suffix == ".ply":
            write_ply_points(output, scan.points, scan.scanner)
        else:
            write_las(output, scan.points, scan.scanner, scan.pose, scan.time, scan.intensity)
        write_poses_csv(poses_path(output), scan.stops, scan.stop_times)
    except SnakesimError as e:
        raise click.ClickException(str(e)) from None
    c = scan.counts
    click.echo(f"wrote {output}: {len(scan)} points from {poses} stops ({c['beams']} beams, {c['returns']} "
               f"returns; lost: {c['grazing']} grazing, {c['masked']} masked, {c['dropout']} dropout, "
               f"{c['thinned']} thinned; {c['off_surface']} mesh hits off the surface not counted) and "
               f"{poses_path(output)}", err=True)
