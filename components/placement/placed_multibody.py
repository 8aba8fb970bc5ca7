"""The multibody, started in a fitted shape: ``shape:`` -> ``q0``, ``base_position``, ``base_quaternion``.

    robot:
      type: placed_multibody
      params: {design: eels-1.5, modules: 4,
               shape: {kind: helix, radius: 0.25, pitch: 2.0, pose: {position: [0, 0, 0]}}}

Everything else is the multibody's (ports, parameters, state): see
components/multibody/component.py. The fit (fit.py) runs when the parameters
are validated, so the resolved configuration (``snakesim run --dump``) shows
the fitted q0 and base pose beside the shape; when ``shape`` is given it
replaces q0 and the base pose (a re-run of that file fits the same values).
Why a parameter transform and not a component: the initial state is the
multibody's own, fixed before the first step, and no other component may
write another's state.
"""

from __future__ import annotations

from pydantic import Field, model_validator

from ..multibody.component import Multibody, MultibodyParams
from .fit import fit_shape
from .shapes import Shape


class PlacedMultibodyParams(MultibodyParams):
    shape: Shape | None = Field(None, description="initial shape guess; replaces q0 and the base pose")
    limits: dict[str, float] = Field(default_factory=dict, description="rad per joint kind (bend, twist) for the fit")

    @model_validator(mode="after")
    def _place(self):
        if self.shape is not None:
            pl = fit_shape(self, self.shape, self.limits)
            object.__setattr__(self, "q0", pl.q0)
            object.__setattr__(self, "base_position", pl.base_position)
            object.__setattr__(self, "base_quaternion", pl.base_quaternion)
        return self


class PlacedMultibody(Multibody):
    type_name = "placed_multibody"
    Params = PlacedMultibodyParams
