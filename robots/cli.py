"""``snakesim robot urdf``: a design's URDF for any module count, with its screw meshes.

A plugin command (registered by the built-in plugin, ``components/plugin.py``), not a framework
one: the framework knows nothing about snake robots. The generator is the same one that writes the
committed 10-module files (``python -m snakesim.robots.generate``).

Layout written: ``FILE`` and, beside it, ``meshes/screw_*.stl``; the URDF names its meshes
``meshes/<file>``, relative to itself, so the pair can be moved together and
``snakesim run --urdf FILE`` (and the viewer) find them.
"""

from __future__ import annotations

from pathlib import Path

import click

from snakesim.framework.errors import SnakesimError

#: how the generator names a mesh (urdf/ and meshes/ siblings) and how the written file names it
GENERATED_MESH_DIR, WRITTEN_MESH_DIR = "../meshes/", "meshes/"


def write_urdf(design: str, modules: int | None, head: bool | None, path: Path) -> tuple[Path, list[Path]]:
    """Write ``design`` with ``modules`` modules to ``path`` and its screw meshes to ``path.parent/meshes``;
    returns (the URDF, the meshes). ValueError/KeyError name a bad design or module count.

    The meshes (and a plugin design's sidecar) are written first, the URDF last, each whole or not at all
    (framework/output_files.py); when any of them cannot be written (a full or read-only disk) what this
    call created is removed again and an OutputError names the file and the cause: no URDF is ever left
    naming meshes that are not there."""
    from snakesim.framework.output_files import OutputSet

    from .designs import DESIGNS
    from .registration import robot_design
    from .screw_mesh import screw_mesh_bytes

    robot = robot_design(design).describe(modules, head)
    path = Path(path)
    text = robot.urdf.replace(f'filename="{GENERATED_MESH_DIR}', f'filename="{WRITTEN_MESH_DIR}')
    mesh_dir = path.parent / WRITTEN_MESH_DIR
    with OutputSet() as out:
        out.make_dir(path.parent)
        meshes = []
        if robot.screw_meshes:
            out.make_dir(mesh_dir)
            for g in robot.screw_meshes.values():
                name, data = screw_mesh_bytes(g)
                target = mesh_dir / name
                if not (target.is_file() and target.stat().st_size == len(data) and target.read_bytes() == data):
                    out.write(target, data)         # the same mesh already there (same name): kept as is
                meshes.append(target)
        if design not in DESIGNS and robot.metadata:
            # a plugin's design: its metadata sidecar beside the URDF, so `--urdf FILE` alone finds it
            import yaml

            stem = path.name[: -len(path.suffix)] if path.suffix else path.name
            out.write(path.with_name(stem + ".snakesim.yaml"), yaml.safe_dump(dict(robot.metadata), sort_keys=False))
        out.write(path, text)                       # last: what the files above serve
    return path, meshes


@click.group("robot")
def robot():
    """Robot descriptions: write a design's URDF for N modules, with its meshes."""


@robot.command("urdf")
@click.option("--robot", "design", required=True,
              help="Design: eels-concept, eels-1.0, eels-1.0-front, eels-1.5, mini-eels-1.0, or a plugin's.")
@click.option("--modules", type=int, default=None, help="Number of modules (default: the design's).")
@click.option("--head/--no-head", default=None, help="Perception head / head cap on or off (default: the design's).")
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="URDF file to write; its meshes go to meshes/ beside it.")
def urdf_command(design, modules, head, output):
    """Write DESIGN's URDF with N modules to FILE (use it with `snakesim run --urdf FILE --robot DESIGN`)."""
    try:
        path, meshes = write_urdf(design, modules, head, output)
    except (KeyError, ValueError) as e:
        raise click.ClickException(str(e.args[0]) if e.args else str(e)) from None
    except SnakesimError as e:      # a full or read-only disk: the file and the cause, nothing partial left
        raise click.ClickException(f"robot urdf -o {output}: {e}") from None
    where = f" and {len(meshes)} screw mesh(es) in {path.parent / WRITTEN_MESH_DIR}" if meshes else ""
    click.echo(f"wrote {path}{where}", err=True)
