"""Robot designs as registrations: what the multibody's ``design:`` (and ``--robot``) can name.

A design is one :class:`RobotDesign`, registered through the plugin hook
``snakesim_register_robot_designs(registry)`` with ``registry.add_robot_design(design)``:

    name             the ``design:`` value (third-party designs carry their package's prefix)
    build            ``build(modules, head, **params)`` -> the robot: ``(urdf_text, metadata)``, where
                     metadata is a sidecar mapping (robots/sidecar.py), or the path of a URDF file
                     (its sidecar, if any, beside it), or a :class:`~.description.RobotDescription`.
                     ``modules`` is the scene's value or ``default_modules``; ``head`` is None unless
                     the scene sets it; ``params`` are the multibody's ``robot:`` mapping. A
                     ValueError or TypeError it raises is reported as a configuration error.
    title            one line for listings
    default_modules  module count when the scene gives none (None: the builder's own)

snakesim's own EELS family registers through the same hook (components/plugin.py); its
builder is :func:`~.description.generate_robot`, so a built-in design's robot is exactly what
``python -m snakesim.robots.generate`` writes.
"""

from __future__ import annotations

import dataclasses
import difflib
from functools import partial
from pathlib import Path
from typing import Any, Callable

from .designs import DESIGNS, UnknownDesignError


@dataclasses.dataclass(frozen=True, eq=False)
class RobotDesign:
    """One robot design: its name, builder and defaults (module docstring)."""

    name: str
    build: Callable[..., Any]
    title: str = ""
    default_modules: int | None = None

    def __post_init__(self):
        if not (isinstance(self.name, str) and self.name.strip()):
            raise TypeError(f"robot design name {self.name!r} must be a non-empty string")
        if not callable(self.build):
            raise TypeError(f"robot design '{self.name}': build {self.build!r} is not callable")

    def describe(self, modules: int | None = None, head: bool | None = None, **params):
        """The design's :class:`~.description.RobotDescription` for these arguments."""
        from .description import RobotDescription

        n = modules if modules is not None else self.default_modules
        kw = {} if head is None else {"head": head}
        built = self.build(n, **kw, **params)
        if isinstance(built, RobotDescription):
            return built
        return description_of(self.name, n, built)


def description_of(name: str, modules: int | None, built) -> Any:
    """A third-party builder's result (``(urdf, metadata)`` or a URDF path) as a RobotDescription, the
    metadata validated against the sidecar schema and the URDF's names."""
    from snakesim.components.multibody.urdf import parse_urdf

    from .description import RobotDescription
    from .sidecar import check_against_urdf, read_sidecar, sidecar_path, validate_metadata

    path = None
    if isinstance(built, (str, Path)) and not str(built).lstrip().startswith("<"):
        path = Path(built).resolve()
        text = path.read_text(encoding="utf-8")
        side = sidecar_path(path)
        metadata = read_sidecar(side) if side else {}
        source = str(side or path)
    elif isinstance(built, tuple) and len(built) == 2 and isinstance(built[0], str):
        text, source = built[0], f"robot design '{name}' metadata"
        metadata = validate_metadata(built[1], source).as_metadata()
    else:
        raise TypeError(f"robot design '{name}': its builder returned {type(built).__name__}; expected "
                        "(urdf_text, metadata), a URDF path or a RobotDescription")
    check_against_urdf(metadata, parse_urdf(text, f"robot design '{name}'"), source)
    return RobotDescription(design=name, modules=modules, urdf=text, metadata=metadata, parameters=None,
                            urdf_path=path, source="generated")


def builtin_robot_designs() -> tuple[RobotDesign, ...]:
    """snakesim's own designs (the EELS family of designs.py), as registrations."""
    from .description import generate_robot

    return tuple(RobotDesign(d.name, partial(generate_robot, d.name), d.title, d.default_modules)
                 for d in DESIGNS.values())


def robot_designs(registry=None) -> dict[str, RobotDesign]:
    """name -> RobotDesign of ``registry`` (default: built-ins plus every installed plugin), built-ins first."""
    from snakesim.framework.registry import default_robot_designs

    reg = registry or default_robot_designs()
    return reg.builtins_first(reg.robot_designs, "robot design")


def robot_design(name: str, registry=None) -> RobotDesign:
    """The registered design ``name``; UnknownDesignError names the valid designs and the closest ones, a
    name two plugins registered is an error naming both."""
    if registry is None:
        from snakesim.framework.registry import default_robot_designs

        registry = default_robot_designs()
    registry._clashed("robot design", name)
    designs = robot_designs(registry)
    if isinstance(name, str) and name in designs:
        return designs[name]
    raise UnknownDesignError(unknown_design_message(name, list(designs)))


def unknown_design_message(name, names: list[str]) -> str:
    query = str(name).strip().lower()
    close = difflib.get_close_matches(query, names, n=3, cutoff=0.5)
    # a fragment such as "mini" or "1.5" is too short for difflib's ratio
    close += [d for d in names if query and query in d and d not in close]
    hint = f" Did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    return f"unknown robot design {name!r}.{hint} Valid designs: {', '.join(names)}"
