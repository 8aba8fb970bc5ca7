"""Multibody dynamics (Pinocchio) of a free-floating robot from a URDF.

:class:`Multibody` is the component and provides the :class:`RobotModel`
(:mod:`.robot_model`) every robot-facing component uses; :mod:`.model` builds the dynamics models
(ABA with the screw-pair embedding, or the mimic/CRBA reference),
:mod:`.kernels` the numba link-tree kernels, :mod:`.report` the multibody
optimisation report and its baselines.
"""

from .component import Multibody, MultibodyParams
from .robot_model import JOINT_KINDS, RobotModel, RobotSource, joint_kind
from .urdf import MultibodyModelError

__all__ = ["Multibody", "MultibodyParams", "MultibodyModelError", "RobotModel", "RobotSource", "JOINT_KINDS",
           "joint_kind"]
