"""ROS 2 sensor bridge: what the perception sensors measure, on the topics a robot's drivers use.

A sink: one per-instance input per sensor output it publishes (``sensors``: 'comp.port'
entries; ``snakesim run --ros2`` wires every output of port role LIDAR_SCAN or CAMERA_FRAME,
components/port_roles.py: a sensor declares what it publishes by the role of its port).
At each tick it publishes the samples that are new since the last tick (a sample is new
when its (seq, t) changed), stamped with the sample's own simulated time. Topics, for a
sensor port 'comp.port' with base B = /comp (the component's only such port) or /comp/port:

    B/points         sensor_msgs/PointCloud2   a LidarScan (.sensor_messages: organised, NaN misses)
    B/image_raw      sensor_msgs/Image         a CameraFrame's image, mono8 or rgb8 (saturated at 1)
    B/depth          sensor_msgs/Image         its depth, 32FC1 m, NaN where nothing is hit
    B/labels         sensor_msgs/Image         its labels, mono16: what each pixel's ray hit (perception/labels.py)
    B/camera_info    sensor_msgs/CameraInfo    its model (pinhole, fisheye, CAHV; none for CAHVOR/E); a
                                               stereo right camera's P[3] = -fx·baseline, R = I
    /tf_static       tf2_msgs/TFMessage        once, transient local: each sensor frame that is not a robot
                                               link, from the link it is mounted on (``mounts``,
                                               :mod:`.sensor_frames`: one parent per frame)
    /tf              tf2_msgs/TFMessage        only for a sample frame ``mounts`` does not name (a bridge
                                               built by hand): its pose from ``world_frame`` at the sample

Every message's ``frame_id`` is the sensor's frame in that tree: the URDF's link where the sensor sits
exactly on one (a lidar on ``lidar``: frame ``lidar``; a camera on ``camera_left``:
``camera_left_optical_frame``, child of ``camera_left``; the stereo right camera on the URDF's
``camera_right`` when that link is where the baseline puts it), else a frame of its own named after the
sample (``stereo_left_optical_frame``) on the mount link. ``snakesim run --ros2`` fills ``mounts`` from
the sensors' params (:func:`.attach.attach_sensor_bridge`) and ``uses`` the sensors' robot.

QoS: reliable, keep last 5 (matches both reliable subscribers, as rviz's, and best-effort ones,
as the sensor-data profile's). Messages are serialised by rosbags' CDR codec and written
through Cyclone's C writer (template.RawWriter).

in   sensor0 .. sensor{k-1}   LidarScan or CameraFrame, one per entry of params.sensors
out  none
"""

from __future__ import annotations

import dataclasses
import weakref

from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Component, Input, Uses

from .sensor_frames import SensorFrameMount, resolve_sensor_frames
from .transport import ClosedAfterRun, DdsEndpoint, TopicQos

SENSOR_QOS = TopicQos(reliable=True, depth=5)


class Ros2SensorBridgeParams(DdsEndpoint):
    sensors: list[str] = Field(default_factory=list, description="sensor outputs published, 'comp.port' each")
    bases: list[str] = Field(default_factory=list, description="topic base per sensor (default: /comp/port)")
    world_frame: str = Field("world", description="parent frame on /tf of a sample frame not in mounts")
    mounts: dict[str, SensorFrameMount] = Field(
        default_factory=dict, description="sample frame name (a LidarScan's or CameraFrame's .frame) -> its "
                                          "mount (link, xyz, rpy, optical, baseline): the frame on /tf_static")


def sensor_input_name(i: int) -> str:
    return f"sensor{i}"


class Ros2SensorBridge(ClosedAfterRun, Component[Ros2SensorBridgeParams]):
    type_name = "ros2_sensor_bridge"
    is_sink = True

    robot = Uses(RobotModel, required=False, doc="the links the sensors are mounted on (URDF frame names)")

    def setup(self):
        p = self.p
        try:
            #: sample frame name -> SensorFrame (the ROS frame, its parent link and transform, the baseline)
            self.frames = resolve_sensor_frames(dict(p.mounts), self.robot)
        except ValueError as e:
            raise ValueError(f"{self.name}: mounts: {e}") from None
        self.links = frozenset(self.robot.links) if self.robot is not None else frozenset()
        if p.bases and len(p.bases) != len(p.sensors):
            raise ValueError(f"{self.name}: bases has {len(p.bases)} entries for {len(p.sensors)} sensors")
        self.bases = list(p.bases) or ["/" + s.replace(".", "/") for s in p.sensors]
        self.add_inputs({sensor_input_name(i): Input(type=object, doc=f"{ref}: a LidarScan or a CameraFrame")
                         for i, ref in enumerate(p.sensors)})

    def make_cache(self, x, u, y):
        return BridgeRun(last=[None] * len(self.p.sensors))

    def update(self, t, xd, u):
        run = u.cache
        if run.dds is None:
            run.now = t
            self._open(run)
        for i, base in enumerate(self.bases):
            sample = getattr(u, sensor_input_name(i))
            if sample is None:
                continue
            key = (sample.seq, sample.t)
            if run.last[i] == key:
                continue
            run.last[i] = key
            self._publish(run, base, sample)

    # -- publishing -----------------------------------------------------------------------------
    def before_run(self, t0, u):
        """The DDS participant, /tf_static and every configured sensor topic's writer, opened before the clock
        starts (so they are in the ``--ros2`` start print and the node's announcement from the start). A
        sensor's kind (lidar: B/points; camera: B/image_raw, B/depth, B/labels, B/camera_info) is its sample's type when
        one is already on the input, else its port's name (a lidar's ``scan``; a camera's ``frame``, a stereo
        pair's ``left``/``right``), else an optical mount; a sensor none of these tells gets its writers at
        its first sample, as before."""
        from . import sensor_messages as SM

        run = u.cache
        if run.dds is None:
            run.now = t0
            self._open(run)
        topics = {"lidar": (("points", SM.POINT_CLOUD2),),
                  "camera": (("image_raw", SM.IMAGE), ("depth", SM.IMAGE), ("labels", SM.IMAGE),
                             ("camera_info", SM.CAMERA_INFO))}
        for i, (ref, base) in enumerate(zip(self.p.sensors, self.bases)):
            kind = self._sensor_kind(ref, getattr(u, sensor_input_name(i), None))
            for suffix, ros_name in topics.get(kind, ()):
                self._writer(run, f"{base}/{suffix}", ros_name)

    def _sensor_kind(self, ref: str, sample) -> str | None:
        """'lidar', 'camera' or None (not known before its first sample): see :meth:`before_run`."""
        from snakesim.components.perception import CameraFrame, LidarScan

        if isinstance(sample, LidarScan):
            return "lidar"
        if isinstance(sample, CameraFrame):
            return "camera"
        comp, _, port = ref.partition(".")
        by_port = {"scan": "lidar", "frame": "camera", "left": "camera", "right": "camera"}
        if port in by_port:
            return by_port[port]
        mount = self.p.mounts.get(comp)
        return "camera" if mount is not None and mount.optical else None

    def _open(self, run: "BridgeRun") -> None:
        from .messages import typestore
        from .transport import Ros2Participant

        run.ts = typestore()
        run.dds = Ros2Participant(self.p.domain_id, self.p.interface)
        run.finalizer = weakref.finalize(run, run.dds.close)
        static = self.static_message(run.now)
        if static.transforms:
            from . import messages as M

            run.dds.writer("/tf_static", M.TFMessage).write(static)

    def _writer(self, run: "BridgeRun", topic: str, ros_name: str):
        from .messages import ros_type
        from .template import RawWriter

        w = run.writers.get(topic)
        if w is None:
            w = run.writers[topic] = RawWriter(run.dds.writer(topic, ros_type(ros_name), SENSOR_QOS))
            self.p.announce(run.dds, "snakesim_sensors")
        return w

    def _publish(self, run: "BridgeRun", base: str, sample) -> None:
        from snakesim.components.perception import CameraFrame, LidarScan

        from . import sensor_messages as SM

        ts = run.ts
        sf = self.frames.get(sample.frame)
        frame_id = self.frame_id(sample.frame)
        if isinstance(sample, LidarScan):
            self._writer(run, f"{base}/points", SM.POINT_CLOUD2).write(SM.point_cloud2(ts, sample, frame_id))
        elif isinstance(sample, CameraFrame):
            self._writer(run, f"{base}/image_raw", SM.IMAGE).write(SM.image(ts, sample, frame_id))
            self._writer(run, f"{base}/depth", SM.IMAGE).write(SM.depth_image(ts, sample, frame_id))
            self._writer(run, f"{base}/labels", SM.IMAGE).write(SM.label_image(ts, sample, frame_id))
            info = SM.camera_info(ts, sample, frame_id, sf.baseline if sf is not None else 0.0)
            if info is not None:
                self._writer(run, f"{base}/camera_info", SM.CAMERA_INFO).write(info)
        else:
            raise TypeError(f"{self.name}: a sensor input got {type(sample).__name__}, not a LidarScan or CameraFrame")
        if sf is None and sample.frame not in self.links or sf is not None and sf.parent is not None:
            self._publish_frame(run, sample)      # a frame of its own (a robot link is the publisher's)
        run.published += 1

    def frame_id(self, sample_frame: str) -> str:
        """The tf frame of the messages of a sample whose ``.frame`` is ``sample_frame``."""
        sf = self.frames.get(sample_frame)
        return sf.frame if sf is not None else sample_frame

    def _publish_frame(self, run: "BridgeRun", sample) -> None:
        """On DDS a mounted frame is on /tf_static (sent once at open); a frame ``mounts`` does not name
        goes on /tf from ``world_frame`` at the sample."""
        from . import messages as M

        if sample.frame in self.frames:
            return
        if run.tf is None:
            run.tf = run.dds.writer("/tf", M.TFMessage)
        run.tf.write(self.frame_message(sample))

    def frame_message(self, sample):
        """The transform that places the sample's frame, stamped at the sample, as a tf2_msgs/TFMessage: a
        mounted frame from its link (the /tf_static transform: one parent), another from ``world_frame``."""
        from . import messages as M

        stamp = M.time_msg(max(sample.t, 0.0))
        sf = self.frames.get(sample.frame)
        if sf is not None and sf.parent is not None:
            return M.TFMessage(transforms=[self._transform(sf, stamp)])
        x, y, z, qx, qy, qz, qw = (float(v) for v in sample.pose)
        return M.TFMessage(transforms=[M.TransformStamped(
            header=M.Header(stamp=stamp, frame_id=self.p.world_frame), child_frame_id=self.frame_id(sample.frame),
            transform=M.Transform(translation=M.Vector3(x, y, z), rotation=M.Quaternion(qx, qy, qz, qw)))])

    def static_message(self, t: float = 0.0):
        """/tf_static: every mounted sensor frame that is not a robot link, from its link (once each)."""
        from . import messages as M

        stamp = M.time_msg(max(t, 0.0))
        seen, out = set(), []
        for sf in self.frames.values():
            if sf.parent is not None and sf.frame not in seen:
                seen.add(sf.frame)
                out.append(self._transform(sf, stamp))
        return M.TFMessage(transforms=out)

    @staticmethod
    def _transform(sf, stamp):
        from . import messages as M

        return M.TransformStamped(header=M.Header(stamp=stamp, frame_id=sf.parent), child_frame_id=sf.frame,
                                  transform=M.Transform(translation=M.Vector3(*sf.translation),
                                                        rotation=M.Quaternion(*sf.rotation)))


@dataclasses.dataclass(eq=False)
class BridgeRun:
    """One run's bridge state (``u.cache``): the participant and writers (opened on the first tick),
    the last sample published per sensor, the count."""

    last: list
    dds: object = None
    ts: object = None
    writers: dict = dataclasses.field(default_factory=dict)
    tf: object = None
    published: int = 0
    finalizer: object = None
    now: float = 0.0                      # sim time of the first tick (the /tf_static stamp)

    def close(self) -> None:
        if self.finalizer is not None:
            self.finalizer()
