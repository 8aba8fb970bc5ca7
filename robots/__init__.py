"""Robot descriptions: parametric URDF generators, generated URDFs and meshes.

The EELS snake-robot family of the EELS-DARTS paper (section 2.1.2) as
parametric generators with systematic dm_control-style names (``module_03``,
``bend_03``, ``twist_03``, ``screw_front_03``, ...). Topologies, frames and
the DOF formulas are documented in :mod:`snakesim.robots.designs`.

Public API::

    load_robot(design, modules=None, head=None, urdf=None, **params) -> RobotDescription
    generate_robot(design, modules=None, head=None, **params) -> RobotDescription
    write_robot(description, root, name=None) -> Path
    DESIGNS  # name -> Design (snakesim's own EELS family)
    RobotDesign, robot_design(name), robot_designs()  # registered designs, plugins' included
    read_sidecar(path), sidecar_path(urdf)            # NAME.snakesim.yaml beside any NAME.urdf

Committed files (default parameters): ``urdf/<design>.urdf`` with its
``urdf/<design>.yaml`` metadata sidecar, and ``meshes/screw_*.stl``;
regenerate them with ``python -m snakesim.robots.generate``.
"""

from .description import RobotDescription, generate_robot, metadata_yaml, write_robot
from .designs import DESIGNS, Design, UnknownDesignError, get_design
from .loader import load_robot
from .registration import RobotDesign, robot_design, robot_designs
from .sidecar import RobotMetadata, RobotMetadataError, read_sidecar, sidecar_path
from .structure import StructureMismatchError, URDFError

__all__ = [
    "DESIGNS",
    "Design",
    "RobotDescription",
    "RobotDesign",
    "RobotMetadata",
    "RobotMetadataError",
    "StructureMismatchError",
    "URDFError",
    "UnknownDesignError",
    "generate_robot",
    "get_design",
    "load_robot",
    "metadata_yaml",
    "read_sidecar",
    "robot_design",
    "robot_designs",
    "sidecar_path",
    "write_robot",
]
