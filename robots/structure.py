"""Structural comparison of a user URDF with a baseline robot (paper 2.1.5).

A user may launch the simulator with their own URDF for a design as long as
it is *structurally similar* to the baseline the generator produces: the same
link names, joint names, joint types, parent/child tree and mimic relations
(which joint follows which). Numbers are free: masses, inertias, origins,
axes, limits, meshes, and mimic multipliers/offsets too -- flipping a screw
joint's axis and the sign of its multiplier describes the same hardware, so
the sign alone cannot be structural.

Parsing uses :mod:`xml.etree.ElementTree`; a file that is not a readable,
self-consistent URDF raises :class:`URDFError` naming the file (and the line
and column for XML syntax errors).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

URDF_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")


class URDFError(ValueError):
    """A URDF that cannot be read: malformed XML, not a <robot>, no links,
    missing required attributes, dangling or duplicate names."""


class StructureMismatchError(ValueError):
    """A URDF whose structure differs from the baseline design.

    ``differences`` holds one human-readable line per difference; the message
    lists them all.
    """

    def __init__(self, source: str, baseline: str, differences: list[str], hint: str | None = None):
        self.source = source
        self.baseline = baseline
        self.differences = list(differences)
        self.hint = hint
        lines = "\n".join(f"  - {d}" for d in self.differences)
        super().__init__((f"{hint}\n" if hint else "") + f"{source} differs in structure from {baseline}:\n{lines}")


@dataclass(frozen=True)
class JointStructure:
    name: str
    type: str
    parent: str
    child: str
    mimic: str | None  # the joint this one mimics, if any


@dataclass(frozen=True)
class UrdfStructure:
    """The structural skeleton of a URDF, in document order."""

    links: tuple[str, ...]
    joints: tuple[JointStructure, ...]
    root: str

    def joint(self, name: str) -> JointStructure | None:
        return next((j for j in self.joints if j.name == name), None)


def parse_structure(text: str, source: str = "<urdf>") -> UrdfStructure:
    """Structure of the URDF in ``text``; ``source`` names it in errors."""
    # imported here: snakesim.components.multibody loads Pinocchio, which `import snakesim.robots` need not
    from snakesim.components.multibody.urdf import robot_element

    robot = robot_element(text, source, URDFError)

    problems: list[str] = []
    links: list[str] = []
    for k, element in enumerate(robot.findall("link"), start=1):
        name = element.get("name")
        if not name:
            problems.append(f"link #{k} has no name")
        elif name in links:
            problems.append(f"link {name!r} is defined twice")
        else:
            links.append(name)
    if not links and not problems:
        raise URDFError(f"{source}: the URDF has no <link> elements")

    joints: list[JointStructure] = []
    for k, element in enumerate(robot.findall("joint"), start=1):
        name = element.get("name")
        label = f"joint {name!r}" if name else f"joint #{k}"
        jtype = element.get("type")
        parent, child, mimic = (element.find(tag) for tag in ("parent", "child", "mimic"))
        parent_link = parent.get("link") if parent is not None else None
        child_link = child.get("link") if child is not None else None
        mimic_joint = mimic.get("joint") if mimic is not None else None
        missing = [
            what for what, ok in (
                ("name attribute", bool(name)), ("type attribute", bool(jtype)),
                ("<parent link=...>", bool(parent_link)), ("<child link=...>", bool(child_link)),
                ("<mimic joint=...>", mimic is None or bool(mimic_joint)),
            ) if not ok
        ]
        if missing:
            problems.append(f"{label} lacks {', '.join(missing)}")
            continue
        if jtype not in URDF_JOINT_TYPES:
            problems.append(f"{label} has unknown type {jtype!r} (URDF types: {', '.join(URDF_JOINT_TYPES)})")
        if any(j.name == name for j in joints):
            problems.append(f"{label} is defined twice")
        for role, link in (("parent", parent_link), ("child", child_link)):
            if link not in links:
                problems.append(f"{label}: {role} link {link!r} is not defined")
        joints.append(JointStructure(name, jtype, parent_link, child_link, mimic_joint))

    joint_names = {j.name for j in joints}
    for j in joints:
        if j.mimic is not None and j.mimic not in joint_names:
            problems.append(f"joint {j.name!r} mimics undefined joint {j.mimic!r}")
    children: dict[str, str] = {}
    for j in joints:
        if j.child in children:
            problems.append(f"link {j.child!r} is the child of two joints ({children[j.child]!r}, {j.name!r})")
        children.setdefault(j.child, j.name)
    roots = [link for link in links if link not in children]
    if links and len(roots) != 1:
        problems.append(
            f"the tree must have exactly one root link, found {len(roots)}"
            + (f": {', '.join(roots)}" if roots else " (the joints form a loop)")
        )
    if problems:
        raise URDFError(f"{source}: not a valid URDF tree:\n" + "\n".join(f"  - {p}" for p in problems))
    return UrdfStructure(tuple(links), tuple(joints), roots[0])


def read_urdf(path: str | Path) -> str:
    """Text of the URDF file at ``path``; errors name the file."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"URDF file not found: {path}")
    if path.is_dir():
        raise URDFError(f"{path}: is a folder, expected a URDF file")
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise URDFError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def structural_differences(candidate: UrdfStructure, baseline: UrdfStructure) -> list[str]:
    """One readable line per structural difference, candidate vs baseline."""
    out: list[str] = []
    if candidate.root != baseline.root:
        out.append(f"root link {candidate.root!r}, baseline {baseline.root!r}")
    for base in baseline.joints:
        cand = candidate.joint(base.name)
        if cand is None:
            continue
        label = f"joint {base.name!r}"
        for attribute in ("type", "parent", "child"):
            mine, theirs = getattr(cand, attribute), getattr(base, attribute)
            if mine != theirs:
                out.append(f"{label}: {attribute} {mine!r}, baseline {theirs!r}")
        if cand.mimic != base.mimic:
            if base.mimic is None:
                out.append(f"{label}: mimics {cand.mimic!r}, baseline has no mimic")
            elif cand.mimic is None:
                out.append(f"{label}: no mimic, baseline mimics {base.mimic!r}")
            else:
                out.append(f"{label}: mimics {cand.mimic!r}, baseline mimics {base.mimic!r}")
    out += _membership("link", candidate.links, baseline.links)
    out += _membership("joint", [j.name for j in candidate.joints], [j.name for j in baseline.joints])
    return out


def check_structure(candidate: UrdfStructure, baseline: UrdfStructure, source: str, baseline_label: str,
                    hint=None) -> None:
    """Raise :class:`StructureMismatchError` listing every difference, if any; ``hint()`` (called only
    then) may give a first line saying what would match."""
    differences = structural_differences(candidate, baseline)
    if differences:
        raise StructureMismatchError(source, baseline_label, differences, hint() if hint else None)


def _membership(kind: str, candidate: list[str] | tuple[str, ...], baseline: list[str] | tuple[str, ...]) -> list[str]:
    cand, base = set(candidate), set(baseline)
    out = [f"{kind} {name!r}: missing (baseline has it)" for name in baseline if name not in cand]
    out += [f"{kind} {name!r}: not in the baseline" for name in candidate if name not in base]
    return out
