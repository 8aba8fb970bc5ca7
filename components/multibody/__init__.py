"""Multibody dynamics (Pinocchio) of a free-floating robot from a URDF.

:class:`Multibody` is the component; :mod:`.model` builds the dynamics models
(ABA with the screw-pair embedding, or the mimic/CRBA reference),
:mod:`.kernels` the numba link-tree kernels, :mod:`.report` the multibody
optimisation report and its baselines.
"""

from .component import Multibody, MultibodyParams
from .urdf import MultibodyModelError

__all__ = ["Multibody", "MultibodyParams", "MultibodyModelError"]
