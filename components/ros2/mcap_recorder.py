"""ROS 2 topics recorded to an MCAP file with ROS 2 schemas (``snakesim run --ros2-mcap FILE``).

The ``ros2_mcap`` sink is the publisher (:class:`.publisher.Ros2Publisher`)
with a file instead of DDS: the same params, inputs, rates and message
templates, so each message's bytes in the file are exactly the CDR bytes the
publisher hands to Cyclone for that topic at that tick (encapsulation header
included). Channels: topic ``/joint_states`` etc., message encoding ``cdr``;
schemas: encoding ``ros2msg``, the .msg text with its dependencies as ROS 2
writes it (from rosbags' standard definitions, :func:`schema_text`), so
``ros2 bag``, Foxglove and ``mcap-ros2-support`` decode it. Log and publish
times are simulated time (ns). ``/robot_description`` and ``/tf_static`` (the
URDF's fixed joints, as the publisher latches them; QoS metadata transient
local) are written once, on the first tick; ``/sim/real_time_factor``
(std_msgs/Float64, sim s per wall s over the last window) at its rate, as
published. With perception sensors in the scene, ``--ros2-mcap`` also adds a
``ros2_sensor_mcap`` (.sensor_mcap) that writes the sensor bridge's topics
(PointCloud2, Image, CameraInfo, the sensor frames on /tf) into the same file.

An interrupted run leaves a readable file: the writer flushes its chunk and
the file every ``flush_period`` wall seconds (and the summary and footer are
written when the component's run ends, or at interpreter exit); a file cut
short (a killed process) lacks the summary and may end in a partial record:
read it record by record (``mcap.reader.NonSeekingReader(f).iter_messages(log_time_order=False)``
up to its ``EndOfFile``), or let ``mcap recover`` rewrite it whole.

    rec: {type: ros2_mcap, rate: 100, params: {path: run.mcap, rates: {tf: 50}}}
    connections: [robot.joint_q -> rec.joint_positions, ...]   # as for ros2_publisher
"""

from __future__ import annotations

import dataclasses
import time
import weakref
from functools import lru_cache
from pathlib import Path

from pydantic import Field

from .publisher import PublisherRun, Ros2Publisher, Ros2PublisherParams

PROFILE = "ros2"


class Ros2McapParams(Ros2PublisherParams):
    path: str = Field(..., description="MCAP file to write (replaced if it exists)")
    flush_period: float = Field(1.0, gt=0, description="wall s between chunk flushes (what a killed run loses)")
    chunk_size: int = Field(1 << 20, gt=0, description="bytes per chunk before it is written (zstd compressed)")


@lru_cache(maxsize=None)
def schema_text(ros_name: str) -> str:
    """The ROS 2 message definition of ``ros_name`` with its dependencies (``MSG:`` sections), from rosbags."""
    from .messages import typestore

    text, _md5 = typestore().generate_msgdef(ros_name, ros_version=2)
    return text


class McapChannel:
    """Stands where the publisher has a DDS writer: ``write(buf)`` adds the buffer as one message."""

    __slots__ = ("run", "channel_id", "count")

    def __init__(self, run: "McapRun", channel_id: int):
        self.run, self.channel_id, self.count = run, channel_id, 0

    def write(self, buf) -> None:
        run = self.run
        run.writer.add_message(self.channel_id, log_time=run.now_ns, data=bytes(buf), publish_time=run.now_ns,
                               sequence=self.count)
        self.count += 1


class McapMessageWriter:
    """Stands where the publisher has a DDS writer of whole messages (``write(msg)``): serialises like
    ``DataWriter.write`` (padded to 4 bytes) into one MCAP message."""

    __slots__ = ("channel",)

    def __init__(self, channel: McapChannel):
        self.channel = channel

    def write(self, msg) -> None:
        raw = msg.serialize()
        self.channel.write(raw.ljust((len(raw) + 3) & ~3, b"\0"))


class McapFile:
    """An MCAP file with ROS 2 schemas shared by the run's recorders (``ros2_mcap`` and
    ``ros2_sensor_mcap`` write one file): :meth:`shared` opens it (replacing an old file) for the
    first recorder of a path and hands the same writer to the others; each :meth:`release` s its
    share and the last one finishes the file. One channel per topic, one schema per type."""

    _open: dict[Path, "McapFile"] = {}

    def __init__(self, path: Path, chunk_size: int):
        from mcap.writer import CompressionType, Writer

        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self.stream = open(path, "wb")
        self.writer = Writer(self.stream, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self.writer.start(profile=PROFILE, library="snakesim ros2_mcap")
        self.schemas: dict[str, int] = {}
        self.channels: dict[str, int] = {}
        self.users = 0
        self.next_flush = 0.0
        self.closed = False

    @classmethod
    def shared(cls, path: Path, chunk_size: int) -> "McapFile":
        key = Path(path).resolve()
        f = cls._open.get(key)
        if f is None or f.closed:
            f = cls._open[key] = cls(key, chunk_size)
        f.users += 1
        return f

    def channel(self, topic: str, ros_name: str, latched: bool = False) -> int:
        cid = self.channels.get(topic)
        if cid is not None:
            return cid
        sid = self.schemas.get(ros_name)
        if sid is None:
            sid = self.schemas[ros_name] = self.writer.register_schema(
                name=ros_name, encoding="ros2msg", data=schema_text(ros_name).encode())
        meta = {"offered_qos_profiles": _qos_yaml(topic)} if latched or topic in ("/clock", "/tf") else {}
        cid = self.channels[topic] = self.writer.register_channel(topic=topic, message_encoding="cdr",
                                                                  schema_id=sid, metadata=meta)
        return cid

    def flush(self) -> None:
        if not self.closed:
            self.writer.flush()

    def flush_every(self, period: float) -> None:
        """Flush the chunk and the file when ``period`` wall seconds have passed since the last flush
        (what a killed run loses)."""
        now = time.monotonic()
        if now >= self.next_flush:
            if self.next_flush:
                self.flush()
            self.next_flush = now + period

    def release(self) -> None:
        """One recorder is done with the file; the last one writes the summary and footer."""
        self.users -= 1
        if self.users <= 0:
            self.close()

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.writer.finish()
            self.stream.close()
            if McapFile._open.get(self.path) is self:
                del McapFile._open[self.path]


def _qos_yaml(topic: str) -> str:
    """rosbag2's offered_qos_profiles metadata for the topics whose QoS is not the default."""
    from .transport import DEFAULT_QOS, QOS

    q = QOS.get(topic, DEFAULT_QOS)
    return (f"- history: 1\n  depth: {q.depth}\n  reliability: {1 if q.reliable else 2}\n"
            f"  durability: {1 if q.transient_local else 2}\n  deadline:\n    sec: 2147483647\n"
            f"    nsec: 4294967295\n  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n"
            f"  liveliness: 1\n  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: 4294967295\n"
            f"  avoid_ros_namespace_conventions: false")


class Ros2McapRecorder(Ros2Publisher):
    """The ROS 2 publisher's messages, byte for byte, into an MCAP file (``--ros2-mcap FILE``)."""

    type_name = "ros2_mcap"
    Params = Ros2McapParams

    def make_cache(self, x, u, y) -> "McapRun":
        return McapRun(templates=self._make_templates(), published=dict.fromkeys(self.topic_rates, 0))

    def _open(self, run: "McapRun", u) -> None:
        p = self.p
        f = McapFile.shared(Path(p.path), p.chunk_size)
        run.writer = f.writer
        writers = {}
        for key, entry in run.templates.items():
            if key not in self.topic_rates:
                continue
            for topic, typ, tpl in (entry if isinstance(entry, list) else [entry]):
                writers.setdefault(key, []).append((McapChannel(run, f.channel(topic, typ.ros_name)), tpl))
        if p.robot_description and self.robot is not None:
            from . import messages as M

            cid = f.channel("/robot_description", M.String.ros_name, latched=True)
            McapMessageWriter(McapChannel(run, cid)).write(M.String(data=self.robot.urdf))
        if self.static:
            from . import messages as M

            cid = f.channel("/tf_static", M.TFMessage.ros_name, latched=True)
            McapMessageWriter(McapChannel(run, cid)).write(self.static_message(run.now_ns * 1e-9))
        if self.rtf_period:
            from . import messages as M
            from .publisher import RTF_TOPIC

            cid = f.channel(RTF_TOPIC, M.Float64.ros_name)
            run.rtf = (self.rtf_period, McapMessageWriter(McapChannel(run, cid)), M.Float64)
        self._schedule(run, writers, u)
        run.dds = f
        f.flush_every(p.flush_period)
        run.finalizer = weakref.finalize(run, f.release)     # also at interpreter exit

    def update(self, t, xd, u):
        run = u.cache
        run.now_ns = int(t * 1e9 + 0.5) if t > 0 else 0
        if run.dds is None:
            self._open(run, u)
        super().update(t, xd, u)
        run.dds.flush_every(self.p.flush_period)


@dataclasses.dataclass(eq=False)
class McapRun(PublisherRun):
    """One recording's state (``u.cache``): the publisher's, the MCAP writer and the current stamp."""

    writer: object = None
    now_ns: int = 0


# -- ``snakesim run --ros2-mcap FILE`` ---------------------------------------------------------------
MCAP = "ros2_mcap"
SENSOR_MCAP = "ros2_sensor_mcap"
#: the DDS endpoint's params a file recorder has no use for
_DDS_ONLY = ("domain_id", "interface", "node_graph", "ros_distro")


def attach_mcap(resolved, path: str) -> str:
    """Add (or update) a ``ros2_mcap`` sink mirroring the ``--ros2`` publisher (added if missing): its params,
    rate, uses and connections, plus ``path``; and, when the scene has perception sensors, a
    ``ros2_sensor_mcap`` mirroring the sensor bridge into the same file. The publisher recorder's name."""
    from .attach import SENSOR_BRIDGE, attach_ros2

    pub = attach_ros2(resolved)
    name = _mirror(resolved, pub, MCAP, path)
    bridge = next((n for n, s in resolved.components.items() if s.type == SENSOR_BRIDGE), None)
    if bridge is not None:
        _mirror(resolved, bridge, SENSOR_MCAP, path)
    return name


def sync_recorder(resolved, pub: str) -> None:
    """Make the ``--ros2-mcap`` recorder mirror publisher ``pub`` again (after its params or rate changed)."""
    name = _recorder(resolved, MCAP)
    if name is not None:
        _mirror(resolved, pub, MCAP, resolved.components[name].params["path"])


def _recorder(resolved, type_name: str) -> str | None:
    return next((n for n, s in resolved.components.items()
                 if s.type == type_name and resolved.where.get(n) == "--ros2-mcap"), None)


def _mirror(resolved, source: str, type_name: str, path: str) -> str:
    """The ``--ros2-mcap`` recorder of ``type_name`` (added if missing) as a copy of the DDS component
    ``source``: its params (less the DDS endpoint's) and ``path``, its rate and uses, its connections."""
    name = _recorder(resolved, type_name)
    if name is None:
        name, k = type_name, 1
        while name in resolved.components:
            name, k = f"{type_name}_{k}", k + 1
    resolved.where[name] = "--ros2-mcap"
    spec = resolved.components[source]
    params = {k: v for k, v in spec.params.items() if k not in _DDS_ONLY}
    resolved.components[name] = spec.model_copy(update={"type": type_name, "params": {**params, "path": str(path)}})
    resolved.connections[:] = [c for c in resolved.connections if not c[1].startswith(f"{name}.")]
    resolved.connections.extend((s, f"{name}.{d.split('.', 1)[1]}", "--ros2-mcap")
                                for s, d, _w in list(resolved.connections) if d.startswith(f"{source}."))
    return name
