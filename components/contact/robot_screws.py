"""The robot's screws as contact models need them: where each screw sits, how it spins, its thread.

Sharing the robot description. A contact component takes the same robot-source
parameters as the multibody (``design``, ``modules``, ``head``, ``urdf``, ``robot``;
see :class:`RobotSource`), so an assembly passes one scene parameter to both::

    parameters:
      robot: {name: eels-1.0, modules: 4, head: true, urdf: null}
    components:
      robot:   {type: multibody, params: {design: "${robot.name}", modules: "${robot.modules}", ...}}
      contact: {type: screw_sdf_contact, params: {design: "${robot.name}", modules: "${robot.modules}", ...}}

Both resolve the URDF through :func:`snakesim.components.multibody.layout.layout_of`
(cached per source), so link rows and DOF joint order are the multibody's by
construction. The URDF gives each screw joint's parent link, origin, axis and
``<mimic>`` relation; the design's metadata sidecar (``snakesim.robots``) gives
what URDF cannot: radius, length, lead angle and thread hand.

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

import json
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np


from snakesim.components.multibody.robot_source import RobotSource  # noqa: F401  (re-exported)

HANDS = {"right": 1, "left": -1}
_CACHE: dict[str, "ScrewLayout"] = {}


class RobotScrewError(ValueError):
    """The robot source gives no usable screw description; the message says what to give."""


@dataclass(frozen=True)
class ScrewLayout:
    names: tuple[str, ...]          # screw joint names
    links: tuple[str, ...]          # every URDF link, multibody row order
    joints: tuple[str, ...]         # DOF joints, multibody order
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


def screw_layout(p) -> ScrewLayout:
    """Screw layout for robot-source params ``p`` (any object with the RobotSource fields); cached."""
    key = json.dumps({k: getattr(p, k) for k in RobotSource.model_fields}, sort_keys=True, default=str)
    lay = _CACHE.get(key)
    if lay is None:
        lay = _build(p)
        if len(_CACHE) > 32:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = lay
    return lay


def _build(p) -> ScrewLayout:
    from snakesim.components.multibody.layout import layout_of
    from snakesim.robots import load_robot

    if p.design is None:
        raise RobotScrewError("screw contact needs the robot's screw geometry (radius, length, lead angle, hand), "
                              "which only a snakesim.robots design carries: give 'design' (eels-concept, eels-1.0, "
                              "eels-1.0-front, eels-1.5), with 'urdf' as the path of your URDF of that design if any")
    src = SimpleNamespace(**{k: getattr(p, k) for k in RobotSource.model_fields}, fts_cuts=[])
    lay = layout_of(src)          # validates the source (errors name it) and fixes the row order
    meta = load_robot(p.design, modules=p.modules, head=p.head, urdf=p.urdf, **p.robot).metadata
    screws = meta.get("screws") or []
    if not screws:
        raise RobotScrewError(f"design '{p.design}' has no screws (metadata 'screws' is empty): nothing for screw "
                              "contact to sample; use a screw-propelled design")
    tree = lay.tree
    rows = {name: i for i, name in enumerate(lay.links)}
    dof = {name: i for i, name in enumerate(lay.joints)}
    cols = {k: [] for k in ("parent_row", "screw_row", "mount_R", "mount_p", "radius", "length", "lead_angle",
                            "hand", "spin_dof", "spin_mult")}
    for s in screws:
        j = tree.joint_by_name.get(s["joint"])
        if j is None or not j.moving:
            raise RobotScrewError(f"metadata screw joint '{s['joint']}' is not a moving joint of {tree.source}")
        if s.get("hand") not in HANDS:
            raise RobotScrewError(f"screw '{s['joint']}': hand {s.get('hand')!r} is not one of {', '.join(HANDS)}")
        if j.mimic is None:
            drive, mult = j.name, 1.0
        else:
            drive, mult = j.mimic[0], float(j.mimic[1])
        cols["parent_row"].append(rows[j.parent])
        cols["screw_row"].append(rows[j.child])
        cols["mount_R"].append(j.rotation @ _axis_frame(np.asarray(j.axis, float)))
        cols["mount_p"].append(np.asarray(j.translation, float))
        cols["radius"].append(float(s["radius"]))
        cols["length"].append(float(s["length"]))
        cols["lead_angle"].append(float(s["lead_angle"]))
        cols["hand"].append(HANDS[s["hand"]])
        cols["spin_dof"].append(dof[drive])
        cols["spin_mult"].append(mult)
    ints = ("parent_row", "screw_row", "hand", "spin_dof")
    arrays = {k: np.array(v, dtype=np.int64 if k in ints else np.float64) for k, v in cols.items()}
    return ScrewLayout(names=tuple(s["joint"] for s in screws), links=tuple(lay.links), joints=tuple(lay.joints),
                       **arrays)
