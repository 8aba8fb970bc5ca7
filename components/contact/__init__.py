"""Screw–terrain contact (paper §2.2.2): penalty normal force, isotropic and anisotropic
friction kernels (numpy and numba), screw contact samples, the analytic screw-pair steady
speed, the fig. 6 friction fit (``snakesim fit-friction``), and the SDF back end
(``screw_sdf_contact``: screw samples against the terrain SDF). The screw speed drive
that contact scenes use lives in control (``screw_drive``)."""

from .kernels import (anisotropic_friction, contact_forces, ev_magnitude, isotropic_friction, normal_force,
                      slip_direction, tangent_axis, tangential_velocity)
from .kernels_numba import body_wrenches_nb, contact_forces_nb, contact_forces_numba
from snakesim.components.materials import Material, MaterialPatch, material_table   # the one material schema

from .point_contact import PointContact, PointContactParams
from .screw_samples import ScrewContactSamples, body_wrench, body_wrenches, thread_direction
from .steady_state import steady_axial_speed
from .contact_set import ContactSet
from .robot_screws import RobotScrewError, ScrewLayout, screw_layout
from .screw_sdf import ScrewSdfContact, ScrewSdfContactParams

__all__ = ["anisotropic_friction", "contact_forces", "ev_magnitude", "isotropic_friction", "normal_force",
           "slip_direction", "tangent_axis", "tangential_velocity", "contact_forces_nb", "contact_forces_numba",
           "body_wrenches_nb", "Material", "MaterialPatch", "material_table", "PointContact", "PointContactParams", "ScrewContactSamples", "body_wrench", "body_wrenches",
           "thread_direction", "steady_axial_speed", "ContactSet", "RobotScrewError", "ScrewLayout", "screw_layout",
           "ScrewSdfContact", "ScrewSdfContactParams"]
