"""The simulator's entry point for robots: pick a design, optionally swap in a
user URDF that must match the design's structure (paper 2.1.5)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from .description import URDF_DIR, RobotDescription, generate_robot
from .structure import check_structure, parse_structure, read_urdf


def load_robot(design: str, modules: int | None = None, head: bool | None = None,
               urdf: str | Path | None = None, **params: Any) -> RobotDescription:
    """Robot description for ``design`` (a key of :data:`~snakesim.robots.DESIGNS`).

    modules: module count, 1..100 (design default if None).
    head: perception head / head cap on or off, for designs that have one.
    urdf: a user URDF file to use instead of the generated one. It must have
        the structure of the generated baseline for the same design, module
        count and head option; numbers may differ. Otherwise
        :class:`~snakesim.robots.structure.StructureMismatchError` lists
        every difference.
    params: ``hand``, ``lead_angle``, ``screw_radius``, ``module_length``.

    Raises UnknownDesignError (a KeyError and ValueError) for an unknown
    design, ValueError for bad parameters, FileNotFoundError for a missing
    ``urdf`` file and URDFError for an unreadable one.
    """
    generated = generate_robot(design, modules, head, **params)
    if urdf is None:
        committed = URDF_DIR / f"{generated.design}.urdf"
        if committed.exists() and committed.read_text(encoding="utf-8") == generated.urdf:
            return replace(generated, urdf_path=committed)
        return generated

    path = Path(urdf)
    text = read_urdf(path)
    candidate = parse_structure(text, str(path))
    baseline = parse_structure(generated.urdf, f"{generated.design} baseline")
    label = f"{generated.design} ({generated.modules} module{'s' if generated.modules != 1 else ''})"
    check_structure(candidate, baseline, str(path), label)
    return replace(generated, urdf=text, urdf_path=path.resolve(), source="user")
