"""Where the perception sensors' frames hang in the ROS 2 tf tree: one parent each, the link they are on.

A sensor sample names its frame (``LidarScan.frame``, ``CameraFrame.frame``: the component's name, a
stereo pair's ``NAME/left`` and ``NAME/right``). The sensor bridge is told each one's mount
(:class:`SensorFrameMount`: the link, ``xyz``, ``rpy``, whether the mount frame is turned to the optical
one, and a stereo right camera's ``baseline`` along the optical +x), and :func:`resolve_sensor_frames`
gives the ROS frame it publishes under, with the rule:

1. the sensor's body frame (the mount without the optical turn, the right camera moved by the baseline)
   is looked up among the robot's links fixed to the mount link (the link itself, or a link joined to it
   by fixed joints at that pose, to 1e-9 m and 1e-9 rad): the URDF's ``lidar``, ``camera_left``,
   ``camera_right`` when the sensor sits exactly there;
2. found, a non-optical sensor's frame *is* that link (no transform of its own: the publisher has the link
   on /tf or /tf_static), and a camera's is ``<link>_optical_frame``, child of that link by the optical turn
   only (REP 103: z forward, x right, y down);
3. not found, the frame is the sample's name (``/`` turned to ``_``; a camera's with ``_optical_frame``),
   with ``_sensor`` appended if a robot link already has that name, child of the mount link by the whole
   mount (xyz, rpy, optical turn, baseline).

Every such frame is fixed to its link: the bridge publishes the transforms once on /tf_static (transient
local), and the messages' ``frame_id`` is the resolved frame.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

Vec3 = tuple[float, float, float]
#: a sensor pose equals a link's within this (m, and rad through the rotation matrix's entries)
MATCH_TOL = 1e-9
OPTICAL_SUFFIX = "_optical_frame"


class SensorFrameMount(BaseModel):
    """A sensor's frame on a robot link, as the sensor component mounts it (perception/mount.py)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)
    link: str = Field(..., description="robot link the sensor is fixed to")
    xyz: Vec3 = Field((0.0, 0.0, 0.0), description="m, sensor origin in the link frame")
    rpy: Vec3 = Field((0.0, 0.0, 0.0), description="rad, sensor axes in the link frame (URDF roll-pitch-yaw)")
    optical: bool = Field(False, description="a camera whose mount frame is turned to the optical frame")
    baseline: float = Field(0.0, ge=0, description="m, a stereo pair's right camera: along the optical +x "
                                                   "of the mount (its CameraInfo P[3] = -fx·baseline)")


@dataclasses.dataclass(frozen=True)
class SensorFrame:
    """A sensor frame in the tf tree. ``parent`` None: the frame is a robot link (its transform is the
    publisher's); else ``translation`` (3,) m and ``rotation`` (x, y, z, w) place it in ``parent``."""

    frame: str
    parent: str | None
    translation: tuple = (0.0, 0.0, 0.0)
    rotation: tuple = (0.0, 0.0, 0.0, 1.0)
    baseline: float = 0.0


def mount_matrices(mount: SensorFrameMount) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R_body, R_sensor, p) of ``mount`` in its link: the body-convention axes, the sensor's axes (the
    optical turn applied when ``optical``) and the sensor origin (moved by the baseline along the
    sensor's x), exactly as the camera and the lidar place themselves."""
    from snakesim.components.multibody.urdf import rpy_matrix
    from snakesim.components.perception.mount import BODY_TO_OPTICAL

    R_body = rpy_matrix(list(mount.rpy))
    R = R_body @ BODY_TO_OPTICAL if mount.optical else R_body
    p = np.asarray(mount.xyz, dtype=float) + R @ np.array([mount.baseline, 0.0, 0.0])
    return R_body, R, p


def fixed_link_poses(robot, link: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{link name: (R, p)}: every link joined to ``link`` by fixed joints only, in ``link``'s frame."""
    poses = {link: (np.eye(3), np.zeros(3))}
    if robot is None:
        return poses
    fixed = [j for j in robot.tree.joints if j.type == "fixed"]
    grew = True
    while grew:
        grew = False
        for j in fixed:
            R_j, p_j = np.asarray(j.rotation, dtype=float), np.asarray(j.translation, dtype=float)
            if j.parent in poses and j.child not in poses:
                R, p = poses[j.parent]
                poses[j.child] = (R @ R_j, R @ p_j + p)
                grew = True
            elif j.child in poses and j.parent not in poses:
                R, p = poses[j.child]                     # parent = child ∘ joint⁻¹
                R_p = R @ R_j.T
                poses[j.parent] = (R_p, p - R_p @ p_j)
                grew = True
    return poses


def _same(R1, p1, R2, p2) -> bool:
    return bool(np.max(np.abs(R1 - R2)) <= MATCH_TOL and np.max(np.abs(p1 - p2)) <= MATCH_TOL)


def _quat(R: np.ndarray) -> tuple:
    from snakesim.components.perception.mount import quaternion_xyzw

    return tuple(float(v) for v in quaternion_xyzw(R))


def resolve_sensor_frames(mounts: dict[str, SensorFrameMount], robot=None) -> dict[str, SensorFrame]:
    """{sample frame name: SensorFrame} by the module's rule; ``robot`` (a RobotModel, or None: only the
    mount link itself is looked at, and no name is checked against the links)."""
    from snakesim.components.perception.mount import BODY_TO_OPTICAL

    links = set(robot.links) if robot is not None else set()
    out: dict[str, SensorFrame] = {}
    taken: dict[str, tuple] = {}
    for name, mount in mounts.items():
        mount = mount if isinstance(mount, SensorFrameMount) else SensorFrameMount(**mount)
        if robot is not None and mount.link not in links:
            raise ValueError(f"sensor frame '{name}': link '{mount.link}' is not a link of robot "
                             f"'{robot.label}'")
        R_body, R, p = mount_matrices(mount)
        at = next((ln for ln, (R_l, p_l) in fixed_link_poses(robot, mount.link).items()
                   if _same(R_body, p, R_l, p_l)), None)
        if at is not None and not mount.optical:
            sf = SensorFrame(at, None, baseline=mount.baseline)
        elif at is not None:
            sf = SensorFrame(at + OPTICAL_SUFFIX, at, rotation=_quat(BODY_TO_OPTICAL), baseline=mount.baseline)
        else:
            frame = name.strip("/").replace("/", "_") + (OPTICAL_SUFFIX if mount.optical else "")
            if frame in links:
                frame += "_sensor"
            sf = SensorFrame(frame, mount.link, tuple(float(v) for v in p), _quat(R), mount.baseline)
        place = (sf.parent, sf.translation, sf.rotation)
        if sf.parent is not None and (sf.frame in links or taken.get(sf.frame, place) != place):
            raise ValueError(f"sensor frame '{name}': frame '{sf.frame}' would have two parents")
        taken[sf.frame] = place
        out[name] = sf
    return out


def sensor_mounts(resolved, registry) -> tuple[dict[str, dict], str | None]:
    """({sample frame name: mount params}, the robot provider's name) of a resolved scene's perception
    sensors (lidar, camera, stereo_camera: their ``link``, ``xyz``, ``rpy``, ``optical``, a stereo pair's
    ``baseline`` on its right view), for the sensor bridge's ``mounts`` and ``uses``. The robot is the
    one the sensors use (their ``uses.robot``), else the first component providing one."""
    from snakesim.components.perception import Camera, Lidar, StereoCamera
    from snakesim.components.viz.attach import provides_robot

    mounts: dict[str, dict] = {}
    robot = sensor_robot = None
    for comp, spec, cls in registry.classes_in(resolved):
        if robot is None and provides_robot(cls):
            robot = comp
        if not (isinstance(cls, type) and issubclass(cls, (Camera, StereoCamera, Lidar))):
            continue
        try:
            prm = cls.Params(**(spec.params or {}))
        except Exception:                 # the build reports invalid params, naming file and key
            continue
        frame = prm.name or comp          # what the samples name (camera.py, lidar.py)
        mount = {"link": prm.link, "xyz": list(prm.xyz), "rpy": list(prm.rpy),
                 "optical": bool(getattr(prm, "optical", False))}
        if issubclass(cls, StereoCamera):
            mounts[f"{frame}/left"] = mount
            mounts[f"{frame}/right"] = {**mount, "baseline": float(prm.baseline)}
        else:
            mounts[frame] = mount
        sensor_robot = sensor_robot or (spec.uses or {}).get("robot")
    return mounts, sensor_robot or robot
