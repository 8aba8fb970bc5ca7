"""The robot's screws as contact models need them: where each screw sits, how it spins, its thread.

Built from the robot a scene names once, on its multibody: contact components declare
``robot = Uses(RobotModel)`` and call ``self.robot.derived(screw_layout)``, so the layout
is built once per robot and its link rows and DOF order are the multibody's by
construction. The URDF (``robot.tree``) gives each screw joint's parent link, origin,
axis and ``<mimic>`` relation; the robot's metadata (``robot.metadata["screws"]``: a
snakesim.robots design's, a plugin design's, or the ``NAME.snakesim.yaml`` sidecar beside a
bare URDF, see snakesim.robots.sidecar) gives what URDF cannot: radius, length, lead angle
and thread hand, and optionally the screw's link (checked to be its joint's child).

Per screw s (arrays of length ns, in metadata order):

    parent_row[s]   row (in link_poses / wrenches) of the body the screw turns on
    screw_row[s]    row of the screw link itself (its origin is on the spin axis)
    mount_R[s]      (3,3) screw frame in the parent frame: column 0 is the spin axis
    mount_p[s]      (3,)  screw centre (= screw joint origin) in the parent frame, m
    radius, length  m (envelope cylinder, centred on the joint origin along the axis)
    lead_angle      rad; hand +1 right / −1 left
    spin_dof        index into joint_v of the DOF that drives it
    spin_mult       spin rate = spin_mult · joint_v[spin_dof] (−1 for the mimic rear
                    screw of a counter-rotating pair, 1 otherwise)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from snakesim.components.multibody.robot_model import RobotModel

HANDS = {"right": 1, "left": -1}
_FIELDS = ("radius", "length", "lead_angle", "hand")


class RobotScrewError(ValueError):
    """The robot gives no usable screw description; the message says what to give."""


@dataclass(frozen=True)
class ScrewLayout:
    names: tuple[str, ...]          # screw joint names
    links: tuple[str, ...]          # every URDF link, multibody row order (= robot.links)
    joints: tuple[str, ...]         # DOF joints, multibody order (= robot.joints)
    parent_row: np.ndarray
    screw_row: np.ndarray
    mount_R: np.ndarray
    mount_p: np.ndarray
    radius: np.ndarray
    length: np.ndarray
    lead_angle: np.ndarray
    hand: np.ndarray
    spin_dof: np.ndarray
    spin_mult: np.ndarray

    @property
    def ns(self) -> int:
        return len(self.names)

    @property
    def nl(self) -> int:
        return len(self.links)

    @property
    def nj(self) -> int:
        return len(self.joints)


def _axis_frame(axis: np.ndarray) -> np.ndarray:
    """Rotation whose first column is ``axis``; the identity for +x (so φ = 3π/2 is −z of the joint)."""
    a = axis / np.linalg.norm(axis)
    if np.allclose(a, (1.0, 0.0, 0.0)):
        return np.eye(3)
    ref = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e2 = np.cross(ref, a)
    e2 /= np.linalg.norm(e2)
    return np.column_stack([a, e2, np.cross(a, e2)])


def screw_layout(robot: RobotModel) -> ScrewLayout:
    """The screw layout of ``robot``; call it as ``robot.derived(screw_layout)`` (built once per robot).

    Raises RobotScrewError when the robot carries no screw metadata (a bare URDF) or its design has no
    screws, or when the metadata does not fit the URDF."""
    meta = robot.metadata
    if "screws" not in meta:
        raise RobotScrewError(
            f"screw contact needs the robot's screw geometry (radius, length, lead angle, hand), which only a "
            f"snakesim.robots design or a metadata sidecar carries, and {robot.label} has no screw metadata: give "
            f"'design' on the multibody (eels-concept, eels-1.0, eels-1.0-front, eels-1.5), with 'urdf' as the path "
            f"of your URDF of that design if any, or put a sidecar NAME.snakesim.yaml beside your NAME.urdf "
            f"declaring its 'screws' (joint, link, hand, lead_angle, radius, length; snakesim.robots.sidecar)")
    screws = meta["screws"] or []
    if not screws:
        raise RobotScrewError(f"design '{robot.design or robot.label}' has no screws (metadata 'screws' is empty): "
                              "nothing for screw contact to sample; use a screw-propelled design, or run the "
                              "design in a scene without screws: mini-eels-crawl, mini-eels-pipe-climb, eels-lateral-undulation, "
                              "eels-sidewinding (shape gaits on body_contact)")
    tree = robot.tree
    cols = {k: [] for k in ("parent_row", "screw_row", "mount_R", "mount_p", "radius", "length", "lead_angle",
                            "hand", "spin_dof", "spin_mult")}
    for s in screws:
        name = s.get("joint")
        j = tree.joint_by_name.get(name)
        if j is None or not j.moving:
            raise RobotScrewError(f"metadata screw joint '{name}' is not a moving joint of {robot.label}")
        missing = [k for k in _FIELDS if k not in s]
        if missing:
            raise RobotScrewError(f"metadata screw '{name}' of {robot.label} lacks {', '.join(missing)}")
        if s.get("link") is not None and s["link"] != j.child:
            raise RobotScrewError(f"metadata screw '{name}' of {robot.label}: link '{s['link']}' is not the link "
                                  f"its joint carries ('{j.child}')")
        if s["hand"] not in HANDS:
            raise RobotScrewError(f"screw '{name}': hand {s['hand']!r} is not one of {', '.join(HANDS)}")
        if j.mimic is None:
            drive, mult = j.name, 1.0
        else:
            drive, mult = j.mimic[0], float(j.mimic[1])
        if drive not in robot.dof_of:
            raise RobotScrewError(f"screw '{name}' is driven by '{drive}', which is not a DOF joint of "
                                  f"{robot.label}; DOF joints: {', '.join(robot.joints)}")
        cols["parent_row"].append(robot.link_row[j.parent])
        cols["screw_row"].append(robot.link_row[j.child])
        cols["mount_R"].append(j.rotation @ _axis_frame(np.asarray(j.axis, float)))
        cols["mount_p"].append(np.asarray(j.translation, float))
        cols["radius"].append(float(s["radius"]))
        cols["length"].append(float(s["length"]))
        cols["lead_angle"].append(float(s["lead_angle"]))
        cols["hand"].append(HANDS[s["hand"]])
        cols["spin_dof"].append(robot.dof_of[drive])
        cols["spin_mult"].append(mult)
    ints = ("parent_row", "screw_row", "hand", "spin_dof")
    arrays = {k: np.array(v, dtype=np.int64 if k in ints else np.float64) for k, v in cols.items()}
    arrays["mount_R"] = arrays["mount_R"].reshape(-1, 3, 3)
    arrays["mount_p"] = arrays["mount_p"].reshape(-1, 3)
    return ScrewLayout(names=tuple(s["joint"] for s in screws), links=robot.links, joints=robot.joints, **arrays)
