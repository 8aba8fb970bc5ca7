"""The odometry component on ROS 2 and in the MCAP recording (``--ros2``, ``--ros2-mcap``).

``ros2_odometry`` is a sink that publishes an ``odometry`` component's outputs
(components/sensors/odometry.py) as nav_msgs/Odometry (:mod:`.odometry_messages`), each tick:

    /odom/ground_truth   the true pose and twist (covariances 0: exact)
    /odom                the dead-reckoning estimate, its measured twist, their model covariances

frame_id ``world_frame`` (the publisher's; the estimate starts at the true pose, so its odom frame
is the world frame), child_frame_id the odometry's link (the twist is in its axes). QoS: ROS 2's
default (reliable, keep last 10). Stamps: simulated time. The DDS participant opens on the first
tick. ``ros2_odometry_mcap`` writes the same bytes into the run's MCAP file (shared with
``ros2_mcap``: :class:`.mcap_recorder.McapFile`), logged at the tick's simulated time.

:func:`attach_odometry` adds (once) the sink for the scene's first ``odometry`` component (found by
class, wired by port role) at that component's rate; :func:`attach_odometry_mcap` mirrors it into a
``--ros2-mcap`` file. A scene without an odometry component gets neither.

in   pose[7], twist[6], estimate_pose[7], estimate_twist[6], estimate_pose_covariance[6, 6],
     estimate_twist_covariance[6, 6]   (from the odometry component)
out  none
"""

from __future__ import annotations

import weakref

from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.sensors.odometry import (DEFAULT_RATE, ODOMETRY_ESTIMATE_POSE, ODOMETRY_ESTIMATE_POSE_COVARIANCE,
                                                  ODOMETRY_ESTIMATE_TWIST, ODOMETRY_ESTIMATE_TWIST_COVARIANCE,
                                                  ODOMETRY_POSE, ODOMETRY_TWIST)
from snakesim.framework import Component, Input, Uses

from .mcap_recorder import McapMirrorParams, open_mirror
from .transport import BridgeRun, ClosedAfterRun, DdsEndpoint

ODOMETRY_BRIDGE = "ros2_odometry"
ODOMETRY_MCAP = "ros2_odometry_mcap"
TRUTH_TOPIC, ESTIMATE_TOPIC = "/odom/ground_truth", "/odom"
#: the odometry component's output role -> the bridge's input
ROLES = {ODOMETRY_POSE: "pose", ODOMETRY_TWIST: "twist", ODOMETRY_ESTIMATE_POSE: "estimate_pose",
         ODOMETRY_ESTIMATE_TWIST: "estimate_twist", ODOMETRY_ESTIMATE_POSE_COVARIANCE: "estimate_pose_covariance",
         ODOMETRY_ESTIMATE_TWIST_COVARIANCE: "estimate_twist_covariance"}


class Ros2OdometryParams(DdsEndpoint):
    world_frame: str = Field("world", description="frame_id of both messages (the estimate starts at the true pose)")
    child_frame: str | None = Field(None, description="child_frame_id: the odometry's link (default: the robot's "
                                                      "root link, as the odometry's default)")
    truth_topic: str = Field(TRUTH_TOPIC, description="topic of the ground truth ('' : off)")
    estimate_topic: str = Field(ESTIMATE_TOPIC, description="topic of the estimate ('' : off)")


class Ros2Odometry(ClosedAfterRun, Component[Ros2OdometryParams]):
    type_name = ODOMETRY_BRIDGE
    is_sink = True
    robot = Uses(RobotModel, required=False, doc="the root link, when child_frame is not given")

    pose = Input(shape=(7,), unit=None, role=ODOMETRY_POSE)
    twist = Input(shape=(6,), unit=None, role=ODOMETRY_TWIST)
    estimate_pose = Input(shape=(7,), unit=None, default=0.0, role=ODOMETRY_ESTIMATE_POSE)
    estimate_twist = Input(shape=(6,), unit=None, default=0.0, role=ODOMETRY_ESTIMATE_TWIST)
    estimate_pose_covariance = Input(shape=(6, 6), unit=None, default=0.0, role=ODOMETRY_ESTIMATE_POSE_COVARIANCE)
    estimate_twist_covariance = Input(shape=(6, 6), unit=None, default=0.0, role=ODOMETRY_ESTIMATE_TWIST_COVARIANCE)

    def setup(self):
        p = self.p
        if p.child_frame is not None:
            self.child_frame = p.child_frame
        elif self.robot is not None:
            self.child_frame = self.robot.tree.root
        else:
            raise ValueError(f"{self.name}: child_frame: give the odometry's link (or bind the robot: its root link)")
        if self.rate is None:
            self.rate = DEFAULT_RATE

    def make_cache(self, x, u, y):
        return OdometryRun()

    def _open(self, run: "OdometryRun") -> None:
        from .template import RawWriter
        from .transport import Ros2Participant

        from .odometry_messages import odometry_type

        run.dds = Ros2Participant(self.p.domain_id, self.p.interface)
        run.writers = {topic: RawWriter(run.dds.writer(topic, odometry_type())) for topic in self._topics()}
        self.p.announce(run.dds, "snakesim_odometry")
        run.finalizer = weakref.finalize(run, run.dds.close)

    def _topics(self) -> list[str]:
        return [t for t in (self.p.truth_topic, self.p.estimate_topic) if t]

    def update(self, t, xd, u):
        from .odometry_messages import OdometryTemplate

        run = u.cache
        if run.templates is None:
            run.templates = (OdometryTemplate(self.p.world_frame, self.child_frame),
                             OdometryTemplate(self.p.world_frame, self.child_frame))
        if run.dds is None:
            self._open(run)
        self._stamp(run, t)
        truth, est = run.templates
        p = self.p
        if p.truth_topic:
            run.writers[p.truth_topic].write(truth.encode(t, u.pose, u.twist))
        if p.estimate_topic:
            run.writers[p.estimate_topic].write(est.encode(t, u.estimate_pose, u.estimate_twist,
                                                           u.estimate_pose_covariance, u.estimate_twist_covariance))
        run.published += 1

    def _stamp(self, run, t) -> None:
        """Where the tick's time goes besides the messages (the MCAP recorder's log time)."""


class OdometryRun(BridgeRun):
    """One run's state (``u.cache``): the message templates, the participant and writers, the count."""


class Ros2OdometryMcapParams(Ros2OdometryParams, McapMirrorParams):
    pass


class Ros2OdometryMcap(Ros2Odometry):
    """The odometry bridge's messages, byte for byte, into an MCAP file (``--ros2-mcap FILE``)."""

    type_name = ODOMETRY_MCAP
    Params = Ros2OdometryMcapParams

    def _open(self, run: OdometryRun) -> None:
        from .odometry_messages import ODOMETRY

        open_mirror(run, self.p, {topic: (ODOMETRY,) for topic in self._topics()})

    def _stamp(self, run, t) -> None:
        run.now_ns = int(t * 1e9 + 0.5) if t > 0 else 0

    def update(self, t, xd, u):
        super().update(t, xd, u)
        u.cache.dds.flush_every(self.p.flush_period)


# -- adding them to a resolved scene ------------------------------------------------------------------
def _first_odometry(resolved, registry):
    """(name, spec, class) of the scene's first odometry component, or None."""
    from snakesim.components.sensors.odometry import Odometry

    for comp, spec, cls in registry.classes_in(resolved):
        if isinstance(cls, type) and issubclass(cls, Odometry):
            return comp, spec, cls
    return None


def attach_odometry(resolved, registry=None, params: dict | None = None) -> str | None:
    """Add (once) a ``ros2_odometry`` sink for the scene's first ``odometry`` component, wired by port role, at
    its rate (rounded to whole base steps); update its params (``params``: the publisher's shared DDS keys,
    ``world_frame``). Its name, or None when the scene has no odometry component."""
    from snakesim.components.viz.attach import provides_robot
    from snakesim.framework.assembly import ComponentSpec
    from snakesim.framework.rates import nearest_period
    from snakesim.framework.registry import default_registry

    from .attach import _free_name, _update_existing

    existing = _update_existing(resolved, ODOMETRY_BRIDGE, params)
    if existing is not None:
        return existing
    registry = registry or default_registry()
    found = _first_odometry(resolved, registry)
    if found is None:
        return None
    comp, spec, cls = found
    prm = {**(params or {})}
    uses = {}
    link = (spec.params or {}).get("link")
    if link is not None:
        prm.setdefault("child_frame", link)
    else:
        robot = (spec.uses or {}).get("robot")
        if robot is None:
            robot = next((c for c, _s, k in registry.classes_in(resolved) if provides_robot(k)), None)
        if robot is not None:
            uses["robot"] = robot
    name = _free_name(resolved, ODOMETRY_BRIDGE)
    rate = 1.0 / (nearest_period(spec.rate or DEFAULT_RATE, resolved.sim.dt) * resolved.sim.dt)
    resolved.components[name] = ComponentSpec(type=ODOMETRY_BRIDGE, params=prm, rate=rate, uses=uses)
    resolved.connections.extend((f"{comp}.{port}", f"{name}.{ROLES[o.role]}", "--ros2")
                                for port, o in cls.outputs.items() if o.role in ROLES)
    resolved.where[name] = "--ros2"
    return name


def attach_odometry_mcap(resolved, path: str, registry=None) -> str | None:
    """Mirror the ``--ros2`` odometry sink (added if the scene has an odometry component) into the
    ``--ros2-mcap`` file ``path`` as a ``ros2_odometry_mcap``. Its name, or None without odometry."""
    from .mcap_recorder import _mirror

    bridge = next((n for n, s in resolved.components.items()
                   if s.type == ODOMETRY_BRIDGE and resolved.where.get(n) == "--ros2"), None)
    if bridge is None:
        bridge = attach_odometry(resolved, registry)
    if bridge is None:
        return None
    return _mirror(resolved, bridge, ODOMETRY_MCAP, path)


def ros2_odometry_components() -> tuple:
    """The component classes this module defines (registered through components/plugin.py's hook)."""
    return (Ros2Odometry, Ros2OdometryMcap)
