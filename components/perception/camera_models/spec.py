"""Camera models from YAML-like mappings, with errors that say where, which key, what value, what is valid.

    {kind: pinhole, fov: 90}                 horizontal fov, degrees, in (0, 180); square pixels, centred
    {kind: pinhole, fx, fy, cx, cy}          pixels
    {kind: fisheye, fov: 180}                equidistant, degrees, in (0, 360]; centred
    {kind: fisheye, f, cx, cy}               f in pixels per radian
    {kind: cahv, c, a, h, v}                 3-vectors, sensor frame
    {kind: cahvor, c, a, h, v, o, r}
    {kind: cahvore, c, a, h, v, o, r, e, linearity}

pydantic checks the form (kind, keys, numbers, finiteness); the models check the geometry.
"""

from __future__ import annotations

from typing import Annotated, Literal, Optional, Union

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError, model_validator

from .base import CameraModel, check_image_size
from .cahv import CahvModel, CahvoreModel, CahvorModel
from .central import FisheyeModel, PinholeModel

Vec3 = tuple[float, float, float]


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)

    def _one_form(self, by_fov: bool, explicit: tuple[str, ...]) -> None:
        given = [key for key in explicit if getattr(self, key) is not None]
        if by_fov and given:
            raise ValueError(f"give either fov or {', '.join(explicit)}, not both (got fov and {', '.join(given)})")
        if not by_fov and len(given) != len(explicit):
            missing = [key for key in explicit if key not in given]
            raise ValueError(f"give fov (degrees) or all of {', '.join(explicit)} (missing {', '.join(missing)})")


class PinholeSpec(_Spec):
    kind: Literal["pinhole"]
    fov: Optional[float] = Field(None, description="degrees, horizontal, edge to edge")
    fx: Optional[float] = None
    fy: Optional[float] = None
    cx: Optional[float] = None
    cy: Optional[float] = None

    @model_validator(mode="after")
    def _form(self):
        self._one_form(self.fov is not None, ("fx", "fy", "cx", "cy"))
        return self

    def build(self, width: int, height: int) -> CameraModel:
        if self.fov is not None:
            return PinholeModel.from_fov(width, height, self.fov)
        return PinholeModel(width, height, self.fx, self.fy, self.cx, self.cy)


class FisheyeSpec(_Spec):
    kind: Literal["fisheye"]
    fov: Optional[float] = Field(None, description="degrees, horizontal, edge to edge")
    f: Optional[float] = Field(None, description="pixels per radian")
    cx: Optional[float] = None
    cy: Optional[float] = None

    @model_validator(mode="after")
    def _form(self):
        self._one_form(self.fov is not None, ("f", "cx", "cy"))
        return self

    def build(self, width: int, height: int) -> CameraModel:
        if self.fov is not None:
            return FisheyeModel.from_fov(width, height, self.fov)
        return FisheyeModel(width, height, self.f, self.cx, self.cy)


class CahvSpec(_Spec):
    kind: Literal["cahv"]
    c: Vec3
    a: Vec3
    h: Vec3
    v: Vec3

    def build(self, width: int, height: int) -> CameraModel:
        return CahvModel(width, height, self.c, self.a, self.h, self.v)


class CahvorSpec(CahvSpec):
    kind: Literal["cahvor"]
    o: Vec3
    r: Vec3

    def build(self, width: int, height: int) -> CameraModel:
        return CahvorModel(width, height, self.c, self.a, self.h, self.v, self.o, self.r)


class CahvoreSpec(CahvorSpec):
    kind: Literal["cahvore"]
    e: Vec3
    linearity: float = Field(description="1 perspective, 0 equidistant fisheye, in between: intermediate")

    def build(self, width: int, height: int) -> CameraModel:
        return CahvoreModel(width, height, self.c, self.a, self.h, self.v, self.o, self.r, self.e, self.linearity)


_SPECS = {
    "pinhole": PinholeSpec, "fisheye": FisheyeSpec, "cahv": CahvSpec, "cahvor": CahvorSpec, "cahvore": CahvoreSpec
}  # fmt: skip
KINDS = tuple(_SPECS)
CameraSpec = Annotated[Union[tuple(_SPECS.values())], Field(discriminator="kind")]
_ADAPTER = TypeAdapter(CameraSpec)


def camera_model_from_spec(spec: dict, width: int, height: int, where: str = "") -> CameraModel:
    """The camera model a spec mapping describes, for a width × height image; ValueError naming ``where``."""
    prefix = f"{where}: " if where else ""
    try:
        check_image_size(width, height)
        parsed = _ADAPTER.validate_python(spec)
    except ValidationError as error:
        raise ValueError(prefix + _describe(error, spec)) from None
    except ValueError as error:
        raise ValueError(f"{prefix}{error}") from None
    try:
        return parsed.build(width, height)
    except ValueError as error:
        raise ValueError(f"{prefix}{parsed.kind} camera: {error}") from None


def _describe(error: ValidationError, spec) -> str:
    kind = spec.get("kind") if isinstance(spec, dict) else None
    problems = []
    for item in error.errors(include_url=False):
        loc = list(item["loc"])
        if loc and loc[0] in _SPECS:
            loc.pop(0)
        key = "".join(f"[{part}]" if isinstance(part, int) else f".{part}" for part in loc).lstrip(".")
        kinds = ", ".join(KINDS)
        match item["type"]:
            case "union_tag_invalid":
                problems.append(f"kind = {kind!r}: unknown camera kind; valid kinds: {kinds}")
            case "union_tag_not_found":
                problems.append(f"kind: missing; give one of {kinds}")
            case "model_attributes_type" | "model_type" | "dict_type":
                problems.append(f"{spec!r}: must be a mapping with a kind ({kinds})")
            case "missing" | "too_long" | "too_short" | "tuple_type" if _is_vector(kind, loc, spec):
                problems.append(f"{loc[0]} = {spec[loc[0]]!r}: must be 3 finite numbers (x, y, z)")
            case "missing":
                problems.append(f"{key}: missing, required for kind {kind}")
            case "extra_forbidden":
                valid = ", ".join(name for name in _SPECS[kind].model_fields if name != "kind")
                problems.append(f"{key} = {item['input']!r}: not a {kind} parameter; valid keys: {valid}")
            case _:
                message = item["msg"].removeprefix("Value error, ")
                problems.append(f"{key} = {item['input']!r}: {message}" if key else f"{kind}: {message}")
    return "camera spec: " + "; ".join(dict.fromkeys(problems))  # once each, in order


def _is_vector(kind, loc, spec) -> bool:
    """The error is about the shape of a 3-vector the spec gives (not about a missing key)."""
    fields = _SPECS[kind].model_fields if kind in _SPECS else {}
    return bool(loc) and loc[0] in fields and fields[loc[0]].annotation == Vec3 and loc[0] in spec
