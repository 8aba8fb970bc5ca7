"""Contact material parameters (validated once, at the boundary).

A material is what `snakesim fit-friction` writes under ``materials.<name>``:
μ and the fig. 6 fit ‖e_v‖ = ev_a + ev_b·F_n, plus the penalty and regularisation
constants the kernels need.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from snakesim.framework import Params

from .kernels import EV_FLOOR


class FrictionMaterial(Params):
    mu: float = Field(0.25, gt=0, description="friction coefficient parallel to the threads")
    ev_a: float = Field(1.0, description="‖e_v‖ at zero normal force")
    ev_b: float = Field(0.0, description="d‖e_v‖/dF_n, 1/N")
    fn_max: float = Field(500.0, gt=0, description="N, top of the working range of F_n per contact")
    ev_floor: float = Field(EV_FLOOR, gt=0, description="smallest admissible ‖e_v‖")
    stiffness: float = Field(1e5, gt=0, description="N/m, penalty spring k (eq. 2)")
    damping: float = Field(1e3, ge=0, description="N·s/m, penalty damper c (eq. 2)")
    v_eps: float = Field(1e-3, ge=0, description="m/s, slip regularisation width")
    regularisation: Literal["sqrt", "linear"] = "sqrt"

    @model_validator(mode="after")
    def _ev_positive_on_range(self):
        # a + b F_n is linear: its minimum over [0, fn_max] is at an end
        lo = min(self.ev_a, self.ev_a + self.ev_b * self.fn_max)
        if lo < self.ev_floor:
            at = 0.0 if self.ev_a <= self.ev_a + self.ev_b * self.fn_max else self.fn_max
            raise ValueError(
                f"‖e_v‖ = ev_a + ev_b·F_n = {self.ev_a:g} + {self.ev_b:g}·F_n falls to {lo:g} at F_n = {at:g} N, "
                f"below ev_floor = {self.ev_floor:g} on the working range [0, fn_max = {self.fn_max:g}] N; "
                f"a non-positive ‖e_v‖ reverses friction along ê_v. Lower fn_max or refit.")
        return self
