"""Launch-time parameters of a generated robot (paper 2.1.5), validated.

The module count and a few geometric knobs may change at launch; everything
else is fixed by the design. Validation errors are ``ValueError`` s that name
the offending value and the accepted range, because they surface straight
from the command line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Real
from typing import Any

from .designs import MAX_MODULES, MIN_MODULES, Design

HANDS = ("right", "left")
PARAMETER_NAMES = ("hand", "lead_angle", "screw_radius", "module_length")
SCREW_PARAMETERS = ("hand", "lead_angle", "screw_radius")


@dataclass(frozen=True)
class RobotParameters:
    """Resolved parameters. Screw fields are None for screwless designs and
    ``head`` is None for designs without a head option.

    hand: thread hand of the front screws ("right"/"left"); rear screws of a
        pair get the other hand.
    lead_angle: thread angle (rad) between the blade and the plane normal to
        the screw axis, measured at the outer radius: tan(lead_angle) =
        lead / (2 pi screw_radius). 0 < lead_angle < pi/2.
    screw_radius: outer (blade tip) radius of the screws (m).
    module_length: distance between consecutive bend axes (m).
    """

    modules: int
    head: bool | None
    module_length: float
    hand: str | None = None
    lead_angle: float | None = None
    screw_radius: float | None = None

    def as_dict(self) -> dict[str, Any]:
        return {
            "modules": self.modules,
            "head": self.head,
            "hand": self.hand,
            "lead_angle": self.lead_angle,
            "screw_radius": self.screw_radius,
            "module_length": self.module_length,
        }


def resolve_parameters(design: Design, modules: int | None = None, head: bool | None = None,
                       **params: Any) -> RobotParameters:
    """Fill defaults from ``design`` and validate every value."""
    unknown = sorted(set(params) - set(PARAMETER_NAMES))
    if unknown:
        raise TypeError(
            f"unknown robot parameter(s) {', '.join(unknown)}; valid: modules, head, {', '.join(PARAMETER_NAMES)}"
        )
    params = {k: v for k, v in params.items() if v is not None}

    n = design.default_modules if modules is None else _module_count(modules)

    if head is not None and not design.has_head_option:
        raise ValueError(f"design {design.name!r} has no head option; leave head unset")
    if head is not None and not isinstance(head, bool):
        raise ValueError(f"head must be True or False, got {head!r}")
    resolved_head = (True if head is None else head) if design.has_head_option else None

    if not design.has_screws:
        given = [p for p in SCREW_PARAMETERS if p in params]
        if given:
            raise ValueError(f"design {design.name!r} has no screws; parameter(s) {', '.join(given)} do not apply")

    dims = design.dimensions
    module_length = _positive_length("module_length", params.get("module_length", dims.module_length))
    min_length = minimum_module_length(design)
    if module_length < min_length:
        raise ValueError(
            f"module_length {module_length} m is too short for {design.name}: it must be at least "
            f"{min_length:.3f} m to fit the bend housing and screws"
        )
    if not design.has_screws:
        return RobotParameters(modules=n, head=resolved_head, module_length=module_length)

    hand = params.get("hand", dims.hand)
    if hand not in HANDS:
        raise ValueError(f"hand must be 'right' or 'left', got {hand!r}")
    lead = params.get("lead_angle", dims.lead_angle)
    if not _is_real(lead) or not 0.0 < float(lead) < math.pi / 2:
        raise ValueError(f"lead_angle {lead!r} rad is outside the valid range 0 < lead_angle < pi/2 (1.5708)")
    radius = _positive_length("screw_radius", params.get("screw_radius", dims.outer_radius))
    return RobotParameters(
        modules=n, head=resolved_head, module_length=module_length,
        hand=hand, lead_angle=float(lead), screw_radius=radius,
    )


def minimum_module_length(design: Design) -> float:
    """Shortest module (m) that still leaves every screw 2 cm long (or a
    2 cm body on screwless designs)."""
    dims = design.dimensions
    screws_per_body = {"pair": 2, "front": 2, "none": 1}[design.screws]  # front-only keeps the pair layout
    min_piece = 0.02
    return dims.knuckle_length + dims.fts_length + screws_per_body * (min_piece + 2 * dims.screw_gap)


def _module_count(modules: Any) -> int:
    if not _is_real(modules) or float(modules) != int(modules):
        raise ValueError(f"module count must be an integer from {MIN_MODULES} to {MAX_MODULES}, got {modules!r}")
    n = int(modules)
    if not MIN_MODULES <= n <= MAX_MODULES:
        raise ValueError(f"module count {n} is outside the valid range {MIN_MODULES}..{MAX_MODULES}")
    return n


def _positive_length(name: str, value: Any) -> float:
    if not _is_real(value) or not 0.0 < float(value) < math.inf:
        raise ValueError(f"{name} {value!r} m is outside the valid range: a finite length > 0")
    return float(value)


def _is_real(value: Any) -> bool:
    return isinstance(value, Real) and not isinstance(value, bool) and math.isfinite(float(value))
