"""The perception sensors' ROS 2 topics recorded to an MCAP file (``snakesim run --ros2-mcap FILE``).

``ros2_sensor_mcap`` is the sensor bridge (:class:`.sensor_bridge.Ros2SensorBridge`) with a file
instead of DDS, as ``ros2_mcap`` is the publisher with a file: the same ``sensors``/``bases``
params and inputs, the same messages byte for byte (``B/points`` PointCloud2, ``B/image_raw``,
``B/depth`` and ``B/labels`` Image, ``B/camera_info`` CameraInfo, the sensor frames on ``/tf``), each logged at its
sample's own simulated time (ns). It writes into the same file as the run's ``ros2_mcap``
recorder when both name one path (:class:`.mcap_recorder.McapFile` is shared per path), so one
bag holds the robot's topics and what its sensors measured, as ``ros2 bag record`` would. Its
channels carry the bridge's QoS (reliable, keep last 5) as offered_qos_profiles.

in   sensor0 .. sensor{k-1}   LidarScan or CameraFrame, one per entry of params.sensors
out  none
"""

from __future__ import annotations

import dataclasses
import weakref
from pathlib import Path

from pydantic import Field

from .mcap_recorder import CHUNK_SIZE, McapChannel, McapFile, McapMessageWriter
from .sensor_bridge import SENSOR_QOS, BridgeRun, Ros2SensorBridge, Ros2SensorBridgeParams


class Ros2SensorMcapParams(Ros2SensorBridgeParams):
    path: str = Field(..., description="MCAP file to write (replaced if it exists; shared with ros2_mcap)")
    flush_period: float = Field(1.0, gt=0, description="wall s at most between a message and its chunk on disk (what a killed run loses)")
    chunk_size: int = Field(CHUNK_SIZE, gt=0, description="bytes per chunk before it is written (zstd compressed)")


class Ros2SensorMcap(Ros2SensorBridge):
    """The sensor bridge's messages, byte for byte, into an MCAP file."""

    type_name = "ros2_sensor_mcap"
    Params = Ros2SensorMcapParams

    def make_cache(self, x, u, y):
        return SensorMcapRun(last=[None] * len(self.p.sensors))

    def before_run(self, t0, u):
        """The shared file and /tf_static, opened before the clock starts, stamped at t0."""
        u.cache.now_ns = int(round(max(t0, 0.0) * 1e9))
        super().before_run(t0, u)

    def _open(self, run: "SensorMcapRun") -> None:
        from .messages import typestore

        run.ts = typestore()
        run.dds = McapFile.shared(Path(self.p.path), self.p.chunk_size, self.p.flush_period)
        run.writer = run.dds.writer
        run.finalizer = weakref.finalize(run, run.dds.release)      # also at interpreter exit
        static = self.static_message(max(run.now_ns, 0) * 1e-9)      # the mounted frames, once, as on the wire
        if static.transforms:
            from . import messages as M

            McapMessageWriter(McapChannel(run, run.dds.channel("/tf_static", M.TFMessage.ros_name))).write(static)

    def _writer(self, run: "SensorMcapRun", topic: str, ros_name: str):
        w = run.writers.get(topic)
        if w is None:
            w = run.writers[topic] = McapChannel(run, run.dds.channel(topic, ros_name, SENSOR_QOS))
        return w

    def _publish(self, run: "SensorMcapRun", base: str, sample) -> None:
        run.now_ns = int(round(max(sample.t, 0.0) * 1e9))              # logged at the sample's time
        super()._publish(run, base, sample)

    def _publish_frame(self, run: "SensorMcapRun", sample) -> None:
        """As on the wire: a mounted frame is on /tf_static (written once at open), another on /tf."""
        from . import messages as M

        if sample.frame in self.frames:
            return
        if run.tf is None:
            run.tf = McapMessageWriter(McapChannel(run, run.dds.channel("/tf", M.TFMessage.ros_name)))
        run.tf.write(self.frame_message(sample))


@dataclasses.dataclass(eq=False)
class SensorMcapRun(BridgeRun):
    """One recording's state (``u.cache``): the bridge's, the shared MCAP file and the current stamp."""

    writer: object = None
    now_ns: int = 0
