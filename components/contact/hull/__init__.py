"""Convex-hull contact back end (paper §2.2.2, fig. 4): coal geometry for the robot's
collision shapes (screw envelopes or convex hulls of the blade mesh, module bodies) against
the terrain and each other; forces with the shared kernels (eqs. 2, 6).

Component ``hull_contact`` (:class:`HullContact`); the SDF back end is ``screw_sdf_contact``.
"""

from .component import HullContact, HullContactParams
from .decompose import hull_error, screw_mesh, slab_hulls, to_coal_convex
from .robot_geometry import GeometryOptions, RobotGeometry, build_robot_geometry, robot_geometry
from .terrain_geometry import terrain_parts

__all__ = ["HullContact", "HullContactParams", "hull_error", "screw_mesh", "slab_hulls", "to_coal_convex",
           "GeometryOptions", "RobotGeometry", "build_robot_geometry", "robot_geometry", "terrain_parts"]
