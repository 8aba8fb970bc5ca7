"""The multibody, started in a fitted shape: ``shape:`` -> ``q0``, ``base_position``, ``base_quaternion``.

    robot:
      type: placed_multibody
      params: {design: eels-1.5, modules: 4,
               shape: {kind: helix, radius: 0.25, pitch: 2.0, pose: {position: [0, 0, 0]}}}

Everything else is the multibody's (ports, parameters, state, and the robot it
provides: ``provides robot: RobotModel``): see components/multibody/component.py.
The fit (fit.py) is a function of the built :class:`RobotModel` and runs in
``setup()``, before the multibody computes its initial state; it writes the
fitted values into the component's parameters, so the resolved configuration
(``snakesim run --dump``, an ``--out`` folder's config.yaml) shows the fitted
q0 and base pose beside the shape. When ``shape`` is given it replaces q0 and
the base pose (a re-run of that file fits the same values).
Why not a component of its own: the initial state is the multibody's own,
fixed before the first step, and no other component may write another's state.
"""

from __future__ import annotations

from pydantic import Field, field_validator

from snakesim.framework import Params

from ..multibody.component import Multibody, MultibodyParams
from ..multibody.robot_model import RobotModel, RobotSource
from .shapes import Shape, shape_of


class PlacedMultibodyParams(MultibodyParams):
    shape: Shape | Params | None = Field(None, description="initial shape guess (a curve, joints, or a registered "
                                         "self-placing kind: shaft_brace); replaces q0 and the base pose")
    limits: dict[str, float] = Field(default_factory=dict, description="rad per joint kind (bend, twist) for the fit")

    @field_validator("shape", mode="before")
    @classmethod
    def _by_kind(cls, value):
        return shape_of(value)          # the kind's own Params (shapes.py: registered placers)


class PlacedMultibody(Multibody):
    type_name = "placed_multibody"
    Params = PlacedMultibodyParams

    def setup(self):
        p = self.p
        if p.shape is not None:
            # the robot Multibody.setup() builds (RobotModel.of is memoised: the same object)
            robot = RobotModel.of(RobotSource.of(p))
            pl = p.shape.place(robot, p.limits)
            self.placement = pl
            self.p = p.model_copy(update={"q0": pl.q0, "base_position": pl.base_position,
                                          "base_quaternion": pl.base_quaternion})
        else:
            self.placement = None
        super().setup()
