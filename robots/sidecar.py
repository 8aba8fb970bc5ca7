"""The robot metadata sidecar: what a URDF cannot say, in a file beside any URDF.

``my-robot.urdf`` may have ``my-robot.snakesim.yaml`` (or ``.snakesim.json``) beside it::

    joints:                          # per moving joint: its kind, optionally its armature
      pitch_0: {kind: bend}
      drive_0: {kind: screw, armature: 0.002}     # kg·m², overrides armature_per_effort
    screws:                          # per screw: the continuous joint that spins it, its link
      - {joint: drive_0, link: auger_0, hand: right, lead_angle: 0.35, radius: 0.05, length: 0.12}
    armature_per_effort: {bend: 2.0e-3, screw: 7.0e-4}   # kg·m² per N·m of effort, by kind

Joint kinds are ``bend``, ``twist``, ``screw`` and ``other``. Where the sidecar names no
kind for a joint, the kind comes from the joint's name (``bend*``, ``twist*``, ``*screw*``,
else ``other``: the systematic names of snakesim.robots). A screw is an envelope cylinder
of ``radius`` and ``length`` (m) centred on its joint's origin along the joint axis,
threaded ``hand`` (right/left) at ``lead_angle`` (rad, from the plane normal to the axis,
at the outer radius); optional ``core_radius``, ``starts``. Every key is checked
(:class:`RobotMetadata`), and an error names the file, the key, the value and what is valid.

A registered design (``RobotDesign``) returns the same mapping from its builder, checked the
same way; snakesim's own designs carry their generated metadata (``robots/urdf/<design>.yaml``),
whose screws have these keys too.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Literal, Mapping

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

JOINT_KINDS = ("bend", "twist", "screw", "other")
JointKind = Literal["bend", "twist", "screw", "other"]
SUFFIXES = (".snakesim.yaml", ".snakesim.yml", ".snakesim.json")


class RobotMetadataError(ValueError):
    """A sidecar that cannot be read or does not validate; the message names file, key, value, valid."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class JointMeta(_Strict):
    kind: JointKind = Field(description="bend | twist | screw | other")
    armature: float | None = Field(None, ge=0, description="kg·m², reflected rotor inertia of this joint")


class ScrewMeta(_Strict):
    joint: str = Field(description="the joint that spins the screw (continuous, or a mimic of one)")
    link: str | None = Field(None, description="the screw's link: the joint's child")
    hand: Literal["right", "left"] = Field(description="thread hand")
    lead_angle: float = Field(gt=0, lt=math.pi / 2, description="rad, thread angle at the outer radius")
    radius: float = Field(gt=0, description="m, envelope (outer) radius")
    length: float = Field(gt=0, description="m, envelope length along the axis, centred on the joint origin")
    core_radius: float | None = Field(None, gt=0, description="m, drum radius (default: 0.75 radius)")
    starts: int | None = Field(None, ge=1, description="thread starts")


class RobotMetadata(_Strict):
    """A metadata sidecar (module docstring)."""

    description: str | None = None
    joints: dict[str, JointMeta] = Field(default_factory=dict)
    screws: list[ScrewMeta] = Field(default_factory=list)
    armature_per_effort: dict[JointKind, float] = Field(default_factory=dict)

    def as_metadata(self) -> dict[str, Any]:
        """The plain mapping a RobotModel carries (``robot.metadata``)."""
        out: dict[str, Any] = self.model_dump(exclude_none=True)
        if not out.get("description"):
            out.pop("description", None)
        return out


def _where(loc) -> str:
    return ".".join(str(p) for p in loc) or "(top level)"


def _explain(e: ValidationError, source: str) -> str:
    lines = []
    for err in e.errors():
        key, kind = _where(err["loc"]), err["type"]
        if kind == "extra_forbidden":
            parent = RobotMetadata
            for part in err["loc"][:-1]:
                ann = {"joints": JointMeta, "screws": ScrewMeta}.get(str(part))
                parent = ann or parent
            valid = ", ".join(parent.model_fields)
            lines.append(f"{source}: unknown key '{key}'; valid keys here: {valid}")
        elif kind == "missing":
            lines.append(f"{source}: '{key}' is missing")
        else:
            lines.append(f"{source}: {key} = {err.get('input')!r}: {err['msg']}")
    return "\n".join(lines)


def validate_metadata(data: Any, source: str) -> RobotMetadata:
    """``data`` (a mapping) checked as a sidecar; RobotMetadataError names ``source``, key, value and
    what is valid."""
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise RobotMetadataError(f"{source}: a robot metadata sidecar is a mapping with keys "
                                 f"{', '.join(RobotMetadata.model_fields)}, not {type(data).__name__}")
    try:
        return RobotMetadata.model_validate(dict(data))
    except ValidationError as e:
        raise RobotMetadataError(_explain(e, source)) from None


def sidecar_path(urdf: str | Path) -> Path | None:
    """The sidecar beside ``urdf`` (``NAME.snakesim.yaml``/``.yml``/``.json`` for ``NAME.urdf``), or None."""
    path = Path(urdf)
    stem = path.name[: -len(path.suffix)] if path.suffix else path.name
    for suffix in SUFFIXES:
        candidate = path.with_name(stem + suffix)
        if candidate.is_file():
            return candidate
    return None


def read_sidecar(path: str | Path) -> dict[str, Any]:
    """The metadata mapping of the sidecar file ``path``, validated."""
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    try:
        data = json.loads(text) if path.suffix == ".json" else yaml.safe_load(text)
    except (json.JSONDecodeError, yaml.YAMLError) as e:
        raise RobotMetadataError(f"{path}: not valid {'JSON' if path.suffix == '.json' else 'YAML'}: {e}") from None
    return validate_metadata(data, str(path)).as_metadata()


def check_against_urdf(metadata: Mapping[str, Any], tree, source: str) -> None:
    """The sidecar's joint and link names exist in the URDF ``tree`` (multibody.urdf.UrdfTree) and each
    screw's link is its joint's child; RobotMetadataError lists the valid names otherwise."""
    moving = [j.name for j in tree.joints if j.moving]
    for name in metadata.get("joints") or {}:
        if name not in moving:
            raise RobotMetadataError(f"{source}: joints.{name}: no moving joint '{name}' in the URDF; "
                                     f"moving joints: {', '.join(moving)}")
    for i, s in enumerate(metadata.get("screws") or []):
        j = tree.joint_by_name.get(s.get("joint"))
        if j is None or not j.moving:
            raise RobotMetadataError(f"{source}: screws.{i}.joint = {s.get('joint')!r}: not a moving joint of the "
                                     f"URDF; moving joints: {', '.join(moving)}")
        if s.get("link") is not None and s["link"] != j.child:
            raise RobotMetadataError(f"{source}: screws.{i}.link = {s['link']!r}: joint '{j.name}' carries link "
                                     f"'{j.child}'")
