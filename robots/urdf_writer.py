"""Serialises a :class:`~snakesim.robots.kinematic_tree.KinematicTree` to URDF text.

Output is deterministic (fixed element order, fixed number formatting) so a
committed URDF can be compared byte for byte with a freshly generated one.
Only standard URDF elements are written: urdfdom (Pinocchio) and any other
URDF parser load the file; per-screw data goes to the YAML sidecar instead.
"""

from __future__ import annotations

from xml.sax.saxutils import escape, quoteattr

from .kinematic_tree import Box, Cylinder, Joint, KinematicTree, Link, Mesh, Pose, Shape, Sphere


def number(value: float) -> str:
    """10 significant digits, no negative zero: stable across runs."""
    text = f"{float(value):.10g}"
    return "0" if text in ("-0", "0") else text


def _vector(values) -> str:
    return " ".join(number(v) for v in values)


def _origin(pose: Pose, indent: str) -> list[str]:
    if pose == Pose():
        return []
    return [f"{indent}<origin xyz={quoteattr(_vector(pose.xyz))} rpy={quoteattr(_vector(pose.rpy))}/>"]


def _geometry(shape: Shape, indent: str) -> list[str]:
    g = shape.geometry
    if isinstance(g, Cylinder):
        element = f'<cylinder radius="{number(g.radius)}" length="{number(g.length)}"/>'
    elif isinstance(g, Box):
        element = f'<box size="{_vector(g.size)}"/>'
    elif isinstance(g, Sphere):
        element = f'<sphere radius="{number(g.radius)}"/>'
    elif isinstance(g, Mesh):
        element = f"<mesh filename={quoteattr(g.filename)}/>"
    else:  # pragma: no cover - the Geometry union is closed
        raise TypeError(f"unsupported geometry {g!r}")
    return [f"{indent}<geometry>", f"{indent}  {element}", f"{indent}</geometry>"]


def _link(link: Link) -> list[str]:
    if link.inertial is None and not link.visuals and not link.collisions:
        return [f"  <link name={quoteattr(link.name)}/>"]
    out = [f"  <link name={quoteattr(link.name)}>"]
    if link.inertial is not None:
        m = link.inertial
        ixx, iyy, izz = m.inertia_diagonal
        out += [
            "    <inertial>",
            f'      <origin xyz="{_vector(m.com)}" rpy="0 0 0"/>',
            f'      <mass value="{number(m.mass)}"/>',
            f'      <inertia ixx="{number(ixx)}" ixy="0" ixz="0" iyy="{number(iyy)}" iyz="0" izz="{number(izz)}"/>',
            "    </inertial>",
        ]
    for shape in link.visuals:
        out.append("    <visual>")
        out += _origin(shape.pose, "      ")
        out += _geometry(shape, "      ")
        if shape.material:
            out.append(f"      <material name={quoteattr(shape.material)}/>")
        out.append("    </visual>")
    for shape in link.collisions:
        out.append("    <collision>")
        out += _origin(shape.pose, "      ")
        out += _geometry(shape, "      ")
        out.append("    </collision>")
    out.append("  </link>")
    return out


def _joint(joint: Joint) -> list[str]:
    out = [
        f"  <joint name={quoteattr(joint.name)} type={quoteattr(joint.type)}>",
        f"    <parent link={quoteattr(joint.parent)}/>",
        f"    <child link={quoteattr(joint.child)}/>",
    ]
    out += _origin(joint.origin, "    ")
    if joint.axis is not None:
        out.append(f'    <axis xyz="{_vector(joint.axis)}"/>')
    if joint.limit is not None:
        lim = joint.limit
        bounds = ""
        if lim.lower is not None and lim.upper is not None:
            bounds = f'lower="{number(lim.lower)}" upper="{number(lim.upper)}" '
        out.append(f'    <limit {bounds}effort="{number(lim.effort)}" velocity="{number(lim.velocity)}"/>')
    if joint.mimic is not None:
        mim = joint.mimic
        out.append(
            f"    <mimic joint={quoteattr(mim.joint)} multiplier=\"{number(mim.multiplier)}\" "
            f"offset=\"{number(mim.offset)}\"/>"
        )
    out.append("  </joint>")
    return out


def to_urdf(tree: KinematicTree, comment: str = "") -> str:
    """URDF text of ``tree``. ``comment`` (plain text) goes into a leading XML
    comment, e.g. the generator command and parameters."""
    out = ['<?xml version="1.0"?>']
    if comment:
        safe = escape(comment).replace("--", "- -")  # "--" may not appear inside XML comments
        out.append(f"<!-- {safe} -->")
    out.append(f"<robot name={quoteattr(tree.name)}>")
    for material in tree.materials:
        out.append(f"  <material name={quoteattr(material.name)}>")
        out.append(f'    <color rgba="{_vector(material.rgba)}"/>')
        out.append("  </material>")
    for link in tree.links:
        out += _link(link)
    for joint in tree.joints:
        out += _joint(joint)
    out.append("</robot>")
    return "\n".join(out) + "\n"
