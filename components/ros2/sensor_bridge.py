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
    B/camera_info    sensor_msgs/CameraInfo    its model (pinhole, fisheye, CAHV; none for CAHVOR/E)
    /tf              tf2_msgs/TFMessage        the sensor frame's pose in ``world_frame`` at the sample
                                               (a star, as the publisher's links)

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

from snakesim.framework import Component, Input

from .transport import DdsEndpoint, TopicQos

SENSOR_QOS = TopicQos(reliable=True, depth=5)


class Ros2SensorBridgeParams(DdsEndpoint):
    sensors: list[str] = Field(default_factory=list, description="sensor outputs published, 'comp.port' each")
    bases: list[str] = Field(default_factory=list, description="topic base per sensor (default: /comp/port)")
    world_frame: str = Field("world", description="parent frame of the sensor frames on /tf")


def sensor_input_name(i: int) -> str:
    return f"sensor{i}"


class Ros2SensorBridge(Component[Ros2SensorBridgeParams]):
    type_name = "ros2_sensor_bridge"
    is_sink = True

    def setup(self):
        p = self.p
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
    def _open(self, run: "BridgeRun") -> None:
        from .messages import typestore
        from .transport import Ros2Participant

        run.ts = typestore()
        run.dds = Ros2Participant(self.p.domain_id, self.p.interface)
        run.finalizer = weakref.finalize(run, run.dds.close)

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
        if isinstance(sample, LidarScan):
            self._writer(run, f"{base}/points", SM.POINT_CLOUD2).write(SM.point_cloud2(ts, sample))
        elif isinstance(sample, CameraFrame):
            self._writer(run, f"{base}/image_raw", SM.IMAGE).write(SM.image(ts, sample))
            self._writer(run, f"{base}/depth", SM.IMAGE).write(SM.depth_image(ts, sample))
            info = SM.camera_info(ts, sample)
            if info is not None:
                self._writer(run, f"{base}/camera_info", SM.CAMERA_INFO).write(info)
        else:
            raise TypeError(f"{self.name}: a sensor input got {type(sample).__name__}, not a LidarScan or CameraFrame")
        self._publish_frame(run, sample)
        run.published += 1

    def _publish_frame(self, run: "BridgeRun", sample) -> None:
        from . import messages as M

        if run.tf is None:
            run.tf = run.dds.writer("/tf", M.TFMessage)
        run.tf.write(self.frame_message(sample))

    def frame_message(self, sample):
        """The sensor frame's pose in ``world_frame`` at the sample, as a tf2_msgs/TFMessage."""
        from . import messages as M

        x, y, z, qx, qy, qz, qw = (float(v) for v in sample.pose)
        return M.TFMessage(transforms=[M.TransformStamped(
            header=M.Header(stamp=M.time_msg(max(sample.t, 0.0)), frame_id=self.p.world_frame),
            child_frame_id=sample.frame,
            transform=M.Transform(translation=M.Vector3(x, y, z), rotation=M.Quaternion(qx, qy, qz, qw)))])


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

    def close(self) -> None:
        if self.finalizer is not None:
            self.finalizer()
