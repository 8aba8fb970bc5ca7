"""The simulator's entry point for robots: pick a design, optionally swap in a
user URDF that must match the design's structure (paper 2.1.5)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from .description import URDF_DIR, RobotDescription
from .sidecar import check_against_urdf, read_sidecar, sidecar_path
from .structure import check_structure, parse_structure, read_urdf


def load_robot(design: str, modules: int | None = None, head: bool | None = None,
               urdf: str | Path | None = None, **params: Any) -> RobotDescription:
    """Robot description for ``design``: a registered design (snakesim's own, :data:`~snakesim.robots.DESIGNS`,
    or a plugin's, ``snakesim_register_robot_designs``).

    modules: module count, 1..100 (design default if None).
    head: perception head / head cap on or off, for designs that have one.
    urdf: a user URDF file to use instead of the generated one. It must have
        the structure of the generated baseline for the same design, module
        count and head option; numbers may differ. Otherwise
        :class:`~snakesim.robots.structure.StructureMismatchError` lists
        every difference. A metadata sidecar beside it (``NAME.snakesim.yaml``,
        robots/sidecar.py) replaces the baseline's keys it declares (screws,
        joints, armature_per_effort).
    params: ``hand``, ``lead_angle``, ``screw_radius``, ``module_length`` (snakesim's designs; a
        plugin's design takes its own).

    Raises UnknownDesignError (a KeyError and ValueError) for an unknown
    design, ValueError for bad parameters, FileNotFoundError for a missing
    ``urdf`` file and URDFError for an unreadable one.
    """
    from .registration import robot_design

    generated = robot_design(design).describe(modules, head, **params)
    if urdf is None:
        committed = URDF_DIR / f"{generated.design}.urdf"
        if (generated.urdf_path is None and committed.exists()
                and committed.read_text(encoding="utf-8") == generated.urdf):
            return replace(generated, urdf_path=committed)
        return generated

    path = Path(urdf)
    text = read_urdf(path)
    candidate = parse_structure(text, str(path))
    baseline = parse_structure(generated.urdf, f"{generated.design} baseline")
    label = f"{generated.design} ({generated.modules} module{'s' if generated.modules != 1 else ''})"
    check_structure(candidate, baseline, str(path), label,
                    hint=lambda: _module_count_hint(design, generated, candidate, str(path), head, params))
    metadata = generated.metadata
    side = sidecar_path(path)
    if side is not None:
        # the user's numbers (screw radius, lead, armature, joint kinds) over the baseline's
        from snakesim.components.multibody.urdf import parse_urdf

        declared = read_sidecar(side)
        check_against_urdf(declared, parse_urdf(text, str(path)), str(side))
        metadata = {**generated.metadata, **declared}
    return replace(generated, urdf=text, urdf_path=path.resolve(), source="user", metadata=metadata)


def _module_count_hint(design: str, generated: RobotDescription, candidate, source: str, head, params) -> str | None:
    """"FILE has the structure of DESIGN with N modules: add --modules N" when it does. A design's link count
    is linear in its modules (two descriptions give the line), so one more description checks the only
    count that could match."""
    from .registration import robot_design
    from .structure import structural_differences

    try:
        d = robot_design(design)
        one, two = (parse_structure(d.describe(n, head, **params).urdf, design) for n in (1, 2))
        per = len(two.links) - len(one.links)
        if per <= 0 or (len(candidate.links) - len(one.links)) % per:
            return None
        n = 1 + (len(candidate.links) - len(one.links)) // per
        if n < 1 or n == generated.modules:
            return None
        if structural_differences(candidate, parse_structure(d.describe(n, head, **params).urdf, design)):
            return None
    except (ValueError, KeyError):            # a count the design does not take: no hint
        return None
    return (f"{source} has the structure of {design} with {n} modules (the scene's robot has "
            f"{generated.modules}): add --modules {n}")
