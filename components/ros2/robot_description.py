"""The URDF as ``/robot_description`` carries it: mesh file names a ROS tool can open.

The robot's URDF names its meshes relative to the URDF file (the generated ones ``../meshes/screw_*.stl``);
rviz2 and Foxglove resolve ``file://`` and ``package://`` URIs only. :func:`ros_robot_description` rewrites
every ``<mesh filename="...">``:

    default                    ``file:///abs/path/screw_....stl``: the file the relative name points at
                               (from the robot's ``base_dir``); a generated screw mesh that is not on disk
                               (a variant's geometry) is written once to ``$XDG_CACHE_HOME/snakesim/meshes``
                               (default ``~/.cache/snakesim/meshes``) and named there
    package=PKG                ``package://PKG/<path relative to package_path>``: for a stack that installs
    package_path=DIR           the meshes as a ROS package (DIR is the folder ``package://PKG/`` stands for;
                               default: the folder holding the robot's ``meshes/``); a mesh outside DIR is an
                               error naming both

Names that already are URIs (``file://``, ``package://``, ``http(s)://``) are kept. Only the published text
changes: the robot's URDF (``RobotModel.urdf``) and ``snakesim robot urdf -o`` keep their relative names.
"""

from __future__ import annotations

import logging
import os
import re
from pathlib import Path

log = logging.getLogger("snakesim.ros2")

_MESH = re.compile(r'(<mesh\b[^>]*?\bfilename\s*=\s*)(["\'])(.*?)\2', re.S)
_SCHEMES = ("file://", "package://", "http://", "https://", "model://")


def mesh_cache_dir() -> Path:
    """Where screw meshes that are not on disk are written for ``file://`` URIs."""
    root = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(root) / "snakesim" / "meshes"


def mesh_path(filename: str, robot) -> Path | None:
    """The file a URDF mesh name (relative or absolute path) names, written to the cache if it is a
    generated screw mesh missing on disk; None when it cannot be found."""
    name = Path(filename)
    base = getattr(robot, "base_dir", None)
    path = name if name.is_absolute() else (Path(base) if base is not None else Path.cwd()) / name
    path = path.resolve()
    if path.is_file():
        return path
    geometry = (getattr(robot, "screw_meshes", None) or {}).get(name.name)
    if geometry is None:
        return None
    from snakesim.robots.screw_mesh import write_screw_mesh

    cache = mesh_cache_dir()
    target = cache / geometry.quantized().filename()
    if not target.is_file():
        cache.mkdir(parents=True, exist_ok=True)
        target = write_screw_mesh(cache, geometry)
    return target.resolve()


def ros_robot_description(robot, package: str | None = None, package_path: str | Path | None = None) -> str:
    """``robot.urdf`` with every mesh file name as a ``file://`` URI (default) or ``package://package/...``
    (see the module docstring)."""
    text = robot.urdf
    missing: list[str] = []

    def uri(m: re.Match) -> str:
        head, quote, name = m.group(1), m.group(2), m.group(3)
        if name.startswith(_SCHEMES):
            return m.group(0)
        path = mesh_path(name, robot)
        if path is None:
            missing.append(name)
            return m.group(0)
        if package is None:
            new = path.as_uri()
        else:
            root = Path(package_path).resolve() if package_path is not None else path.parent.parent
            try:
                rel = path.relative_to(root)
            except ValueError:
                raise ValueError(f"/robot_description: mesh '{path}' is not under mesh_package_path '{root}'; "
                                 f"package://{package}/ cannot name it") from None
            new = f"package://{package}/{rel.as_posix()}"
        return f"{head}{quote}{new}{quote}"

    out = _MESH.sub(uri, text)
    if missing:
        log.warning("/robot_description: mesh file(s) not found, left as in the URDF: %s", ", ".join(sorted(set(missing))))
    return out
