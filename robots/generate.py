"""Write the committed robot files: ``python -m snakesim.robots.generate``.

For every design at its default parameters this writes
``robots/urdf/<design>.urdf``, ``robots/urdf/<design>.yaml`` and the screw
meshes into ``robots/meshes``. A test regenerates the text and compares, so
the committed files cannot go stale silently; ``--check`` does the same from
the command line (exit status 1 when a file differs).

Other folders or module counts are for experiments, e.g.
``python -m snakesim.robots.generate --out /tmp/robots --design eels-1.0 --modules 4``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .description import PACKAGE_DIR, generate_robot, metadata_yaml, write_robot
from .designs import DESIGNS


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m snakesim.robots.generate", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=PACKAGE_DIR,
                        help="folder receiving urdf/ and meshes/ (default: the snakesim.robots package)")
    parser.add_argument("--design", action="append", choices=list(DESIGNS),
                        help="design to write (repeatable; default: all)")
    parser.add_argument("--modules", type=int, default=None, help="module count (default: each design's)")
    parser.add_argument("--check", action="store_true",
                        help="write nothing; exit 1 if a committed file differs from the generated one")
    args = parser.parse_args(argv)

    if args.modules is not None and args.out.resolve() == PACKAGE_DIR:
        parser.error("--modules needs --out: the package folder holds the robots at their default module counts")
    designs = args.design or list(DESIGNS)
    stale: list[str] = []
    referenced: set[str] = set()
    for name in designs:
        try:
            robot = generate_robot(name, modules=args.modules)
        except ValueError as exc:
            parser.error(str(exc))
        referenced.update(robot.screw_meshes)
        if args.check:
            for suffix, text in ((".urdf", robot.urdf), (".yaml", metadata_yaml(robot.metadata))):
                path = args.out / "urdf" / f"{name}{suffix}"
                if not path.exists() or path.read_text(encoding="utf-8") != text:
                    stale.append(str(path))
            stale += [str(args.out / "meshes" / f) for f in robot.screw_meshes if not (args.out / "meshes" / f).exists()]
            continue
        path = write_robot(robot, args.out)
        print(f"wrote {path} ({robot.modules} modules, {len(robot.screw_meshes)} screw mesh(es))")

    if args.check:
        for path in stale:
            print(f"stale: {path}", file=sys.stderr)
        return 1 if stale else 0
    if args.design is None and args.modules is None:
        # a full regeneration owns the mesh folder: drop meshes no design uses any more
        for mesh in sorted((args.out / "meshes").glob("screw_*.stl")):
            if mesh.name not in referenced:
                mesh.unlink()
                print(f"removed unused {mesh}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
