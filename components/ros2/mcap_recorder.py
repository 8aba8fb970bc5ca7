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

A killed run leaves its data on disk: chunks are small (``chunk_size``, 256 KiB by default) and
each goes to the file, unbuffered, the moment it is finished; a chunk in progress is finished and
written after at most ``flush_period`` wall seconds (1 s), by a flusher thread too, so a run held in
lockstep or paused loses nothing it recorded before. What such a file lacks is its summary and
footer (written when the recorders finish, or at interpreter exit), and it may end in a partial
record: ``snakesim mcap recover FILE`` rewrites it whole (:mod:`.mcap_recover`, like ``ros2 bag
reindex`` or the Go ``mcap recover``), or read it record by record with
``mcap.reader.NonSeekingReader(f).iter_messages(log_time_order=False)`` up to its ``EndOfFile``.

A file that cannot be written (a full disk, a quota, a read-only or missing folder) ends the run with an
error naming the file and the operating system's cause (:class:`McapWriteError`, so ``snakesim run`` exits
non-zero); what was written before is kept, marked by its name, as ``FILE.partial`` (``FILE`` itself is not
left half-written), and the error says how to rewrite it whole: ``snakesim mcap recover FILE.partial -o
FILE`` once there is room. Every write goes through :func:`snakesim.framework.output_files._write_all`, the
one write of every output file, so a test makes the Nth write fail as it does for the others.

Every channel carries rosbag2's ``offered_qos_profiles`` metadata: the QoS the topic is offered
with on the wire (:data:`.transport.QOS`, the sensor bridge's for its topics).

    rec: {type: ros2_mcap, rate: 100, params: {path: run.mcap, rates: {tf: 50}}}
    connections: [robot.joint_q -> rec.joint_positions, ...]   # as for ros2_publisher
"""

from __future__ import annotations

import dataclasses
import errno
import threading
import time
import weakref
from functools import lru_cache
from pathlib import Path

from pydantic import Field

from snakesim.framework import Params, output_files
from snakesim.framework.output_files import OutputError

from .publisher import PublisherRun, Ros2Publisher, Ros2PublisherParams

PROFILE = "ros2"
CHUNK_SIZE = 1 << 18          # bytes: small chunks, each on disk as soon as it is finished


class Ros2McapParams(Ros2PublisherParams):
    path: str = Field(..., description="MCAP file to write (replaced if it exists)")
    flush_period: float = Field(1.0, gt=0, description="wall s at most between a message and its chunk on disk (what a killed run loses)")
    chunk_size: int = Field(CHUNK_SIZE, gt=0, description="bytes per chunk before it is written (zstd compressed)")


@lru_cache(maxsize=None)
def schema_text(ros_name: str) -> str:
    """The ROS 2 message definition of ``ros_name`` with its dependencies (``MSG:`` sections), from rosbags."""
    from .messages import typestore

    text, _md5 = typestore().generate_msgdef(ros_name, ros_version=2)
    return text


class McapMirrorParams(Params):
    """A bridge's MCAP mirror (``--ros2-mcap FILE``): the file, shared with ros2_mcap and the other mirrors."""

    path: str = Field(..., description="MCAP file to write (replaced if it exists; shared with ros2_mcap)")
    flush_period: float = Field(1.0, gt=0, description="wall s between chunk flushes (what a killed run loses)")
    chunk_size: int = Field(CHUNK_SIZE, gt=0, description="bytes per chunk before it is written (zstd compressed)")


def open_mirror(run, p: McapMirrorParams, channels: dict) -> None:
    """Point a bridge's ``run`` at the shared MCAP file ``p.path`` instead of DDS: ``run.dds`` the file,
    ``run.writer`` its writer, ``run.writers`` a :class:`McapChannel` per topic of ``channels``
    ({topic: (ROS type name,) or (type name, qos)}), released with the run (also at interpreter exit)."""
    run.dds = McapFile.shared(Path(p.path), p.chunk_size, p.flush_period)
    run.writer = run.dds.writer
    run.writers = {topic: McapChannel(run, run.dds.channel(topic, *spec)) for topic, spec in channels.items()}
    run.finalizer = weakref.finalize(run, run.dds.release)


class McapChannel:
    """Stands where the publisher has a DDS writer: ``write(buf)`` adds the buffer as one message."""

    __slots__ = ("run", "channel_id", "count")

    def __init__(self, run: "McapRun", channel_id: int):
        self.run, self.channel_id, self.count = run, channel_id, 0

    def write(self, buf) -> None:
        run = self.run
        run.dds.add(self.channel_id, run.now_ns, bytes(buf), self.count)
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


class McapWriteError(OutputError):
    """The MCAP file could not be written: its name, the cause, where the partial recording was kept."""


class _Unbuffered:
    """The stream mcap's writer writes to: each write goes straight to the file (the writer writes
    once per finished chunk, once for its message index), so what it finished is on disk, not in a
    buffer a killed process takes with it. (A buffered file flushed after each write: its ``write``
    writes everything or raises, so :func:`output_files._write_all` is the whole write.)"""

    def __init__(self, path: Path):
        self.raw = open(path, "wb")
        self.pos = 0

    def write(self, data) -> int:
        output_files._write_all(self.raw, data)
        self.raw.flush()
        self.pos += len(data)
        return len(data)

    def tell(self) -> int:
        return self.pos

    def flush(self) -> None:
        pass

    def close(self) -> None:
        try:
            self.raw.close()
        except OSError:
            pass                # what the failed write left in the buffer: the file is partial already


class McapFile:
    """An MCAP file with ROS 2 schemas shared by the run's recorders (``ros2_mcap`` and
    ``ros2_sensor_mcap`` write one file): :meth:`shared` opens it (replacing an old file) for the
    first recorder of a path and hands the same writer to the others; each :meth:`release` s its
    share and the last one finishes the file. One channel per topic, one schema per type.

    Kept recoverable while it is written: a chunk is on disk once it holds ``chunk_size`` bytes, and
    a chunk in progress is finished and written at the latest ``flush_period`` wall seconds after its
    first message, by the thread that adds (:meth:`add`) or, when the run adds nothing (held,
    paused, stuck), by a flusher thread. Writer calls take :attr:`lock`."""

    _open: dict[Path, "McapFile"] = {}

    def __init__(self, path: Path, chunk_size: int = CHUNK_SIZE, flush_period: float = 1.0):
        from mcap.writer import CompressionType, Writer

        self.path = path
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            self.stream = _Unbuffered(path)
        except OSError as e:
            raise McapWriteError(f"--ros2-mcap: cannot write {path}: {e.strerror or e}; name a place you can "
                                 "write to") from None
        self.writer = Writer(self.stream, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self.error: McapWriteError | None = None     # the write that failed (raised once, by add or close)
        self.reported = False
        self.closed = False
        self.lock = threading.Lock()
        self._stop = threading.Event()
        try:
            self.writer.start(profile=PROFILE, library="snakesim ros2_mcap")
        except OSError as e:
            self._fail(e)
            self._raise()
        self.schemas: dict[str, int] = {}
        self.channels: dict[str, int] = {}
        self.users = 0
        self.flush_period = flush_period
        self.due = None                   # monotonic time by which the chunk in progress goes to disk
        self.flushes = 0                  # timed flushes so far
        self._flusher = threading.Thread(target=self._flush_loop, name=f"mcap-flush {path.name}", daemon=True)
        self._flusher.start()

    @classmethod
    def shared(cls, path: Path, chunk_size: int = CHUNK_SIZE, flush_period: float = 1.0) -> "McapFile":
        key = Path(path).resolve()
        f = cls._open.get(key)
        if f is None or f.closed:
            f = cls._open[key] = cls(key, chunk_size, flush_period)
        f.flush_period = min(f.flush_period, flush_period)
        f.users += 1
        return f

    def channel(self, topic: str, ros_name: str, qos=None) -> int:
        """The channel of ``topic`` (registered on first use, with its schema and rosbag2's
        offered_qos_profiles for ``qos``, default the topic's on the wire, :data:`.transport.QOS`)."""
        cid = self.channels.get(topic)
        if cid is not None:
            return cid
        with self.lock:
            try:
                sid = self.schemas.get(ros_name)
                if sid is None:
                    sid = self.schemas[ros_name] = self.writer.register_schema(
                        name=ros_name, encoding="ros2msg", data=schema_text(ros_name).encode())
                cid = self.channels[topic] = self.writer.register_channel(
                    topic=topic, message_encoding="cdr", schema_id=sid,
                    metadata={"offered_qos_profiles": qos_yaml(topic, qos)})
            except OSError as e:
                self._fail(e)
                cid = -1                  # nothing more is written: adds to it are dropped
        self._raise()
        return cid

    def add(self, channel_id: int, log_time: int, data: bytes, sequence: int = 0) -> None:
        """One message (log and publish time ``log_time`` ns); writes the chunk when it is full or due.
        Raises :class:`McapWriteError` once the file could not be written (here or by the flusher)."""
        with self.lock:
            if self.error is None:
                try:
                    self.writer.add_message(channel_id, log_time=log_time, data=data, publish_time=log_time,
                                            sequence=sequence)
                except OSError as e:          # a full chunk written, and the disk said no
                    self._fail(e)
                due = self.due
                if due is None:
                    self.due = time.monotonic() + self.flush_period
                elif time.monotonic() >= due:
                    self._flush()
        self._raise()

    def _flush(self) -> None:
        if not self.closed:
            try:
                self.writer.flush()               # the chunk in progress, finished, to the file
            except OSError as e:
                self._fail(e)
                return
            self.due = None
            self.flushes += 1

    def _fail(self, e: OSError) -> None:
        """A write failed (under :attr:`lock`): nothing more is written; the file is closed and kept, marked
        partial by its name, and the error that says so is kept for :meth:`_raise`."""
        self.closed = True
        self._stop.set()
        self.stream.close()
        kept = self.path.with_name(self.path.name + ".partial")
        try:
            self.path.replace(kept)
            where = (f"what was written before is kept as {kept}: `snakesim mcap recover {kept} -o {self.path}` "
                     "rewrites it whole once there is room")
        except OSError:
            kept = self.path
            where = (f"what was written before is left in {kept}, without its summary: `snakesim mcap recover "
                     f"{kept}` rewrites it whole once there is room")
        todo = "free some space or record elsewhere" if e.errno in (errno.ENOSPC, errno.EDQUOT) else \
            "record to a place you can write to"
        self.error = McapWriteError(f"--ros2-mcap: cannot write {self.path}: {e.strerror or e}; the recording "
                                    f"stopped there and {where}; {todo}")

    def _raise(self) -> None:
        """Raise the failed write's error, once (the run's update or, if the flusher met it, its close)."""
        if self.error is not None and not self.reported:
            self.reported = True
            raise self.error

    def flush(self) -> None:
        """Write the chunk in progress to the file now."""
        with self.lock:
            self._flush()

    def flush_every(self, period: float) -> None:
        """Write the chunk in progress when it is due (kept for callers; :meth:`add` and the flusher
        thread do it)."""
        due = self.due
        if due is not None and time.monotonic() >= due:
            self.flush()

    def _flush_loop(self) -> None:
        while True:
            due = self.due
            wait = self.flush_period if due is None else max(due - time.monotonic(), 0.0)
            if self._stop.wait(wait):
                return
            due = self.due
            if due is not None and time.monotonic() >= due:
                with self.lock:
                    if self.due is not None and time.monotonic() >= self.due:
                        self._flush()

    def release(self) -> None:
        """One recorder is done with the file; the last one writes the summary and footer."""
        self.users -= 1
        if self.users <= 0:
            self.close()

    def close(self) -> None:
        """The summary and footer written and the file closed; raises :class:`McapWriteError` if a write
        failed and the run has not been told yet."""
        self._stop.set()
        with self.lock:
            if not self.closed:
                self.closed = True
                try:
                    self.writer.finish()
                    self.stream.close()
                except OSError as e:
                    self._fail(e)
        if self._flusher is not threading.current_thread():
            self._flusher.join(timeout=1.0)
        if McapFile._open.get(self.path) is self:
            del McapFile._open[self.path]
        self._raise()


def qos_yaml(topic: str, qos=None) -> str:
    """rosbag2's offered_qos_profiles metadata (Humble's layout) for ``qos``, default the QoS
    ``topic`` is offered with on the wire."""
    from .transport import DEFAULT_QOS, QOS

    q = qos or QOS.get(topic, DEFAULT_QOS)
    return (f"- history: 1\n  depth: {q.depth}\n  reliability: {1 if q.reliable else 2}\n"
            f"  durability: {1 if q.transient_local else 2}\n  deadline:\n    sec: 2147483647\n"
            f"    nsec: 4294967295\n  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n"
            f"  liveliness: 1\n  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: 4294967295\n"
            f"  avoid_ros_namespace_conventions: false")


_qos_yaml = qos_yaml


class Ros2McapRecorder(Ros2Publisher):
    """The ROS 2 publisher's messages, byte for byte, into an MCAP file (``--ros2-mcap FILE``)."""

    type_name = "ros2_mcap"
    Params = Ros2McapParams

    def make_cache(self, x, u, y) -> "McapRun":
        return McapRun(templates=self._make_templates(), published=dict.fromkeys(self.topic_rates, 0))

    def before_run(self, t0, u):
        """The file and its latched messages, opened before the clock starts, stamped at t0."""
        u.cache.now_ns = int(t0 * 1e9 + 0.5) if t0 > 0 else 0
        super().before_run(t0, u)

    def _open(self, run: "McapRun", u) -> None:
        p = self.p
        f = run.dds = McapFile.shared(Path(p.path), p.chunk_size, p.flush_period)
        run.finalizer = weakref.finalize(run, f.release)     # also at interpreter exit
        run.writer = f.writer
        run.said = True                 # a file, not a DDS endpoint: no start print of domain and topics
        writers = {}
        for key, entry in run.templates.items():
            if key not in self.topic_rates:
                continue
            for topic, typ, tpl in (entry if isinstance(entry, list) else [entry]):
                writers.setdefault(key, []).append((McapChannel(run, f.channel(topic, typ.ros_name)), tpl))
        if p.robot_description and self.robot is not None:
            from . import messages as M

            cid = f.channel("/robot_description", M.String.ros_name)
            McapMessageWriter(McapChannel(run, cid)).write(M.String(data=self.description_text()))
        if self.static:
            from . import messages as M

            cid = f.channel("/tf_static", M.TFMessage.ros_name)
            McapMessageWriter(McapChannel(run, cid)).write(self.static_message(run.now_ns * 1e-9))
        if self.rtf_period:
            from . import messages as M
            from .publisher import RTF_TOPIC

            cid = f.channel(RTF_TOPIC, M.Float64.ros_name)
            run.rtf = (self.rtf_period, McapMessageWriter(McapChannel(run, cid)), M.Float64)
        self._schedule(run, writers, u)

    def update(self, t, xd, u):
        run = u.cache
        run.now_ns = int(t * 1e9 + 0.5) if t > 0 else 0
        if run.dds is None:
            self._open(run, u)
        super().update(t, xd, u)


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
    ``ros2_sensor_mcap`` mirroring the sensor bridge into the same file (the bridge, when added later,
    mirrors itself: :func:`sync_sensor_recorder`). What is on the wire is in the file, whichever
    ``--ros2*`` options come with ``--ros2-mcap``. The publisher recorder's name."""
    from .attach import SENSOR_BRIDGE, attach_ros2

    name = _mirror(resolved, attach_ros2(resolved), MCAP, path)
    bridge = next((n for n, s in resolved.components.items() if s.type == SENSOR_BRIDGE), None)
    if bridge is not None:
        _mirror(resolved, bridge, SENSOR_MCAP, path)
    from .odometry_attach import attach_odometry_mcap
    attach_odometry_mcap(resolved, path)
    from .terrain_map_attach import attach_terrain_map_mcap
    attach_terrain_map_mcap(resolved, path)
    return name


def sync_recorder(resolved, pub: str) -> None:
    """Make the ``--ros2-mcap`` recorder mirror publisher ``pub`` again (after its params or rate changed)."""
    name = _recorder(resolved, MCAP)
    if name is not None:
        _mirror(resolved, pub, MCAP, resolved.components[name].params["path"])


def sync_sensor_recorder(resolved, bridge: str) -> None:
    """When the run records to MCAP (``--ros2-mcap``), make its ``ros2_sensor_mcap`` mirror sensor bridge
    ``bridge`` (added if missing, into the publisher recorder's file)."""
    name = _recorder(resolved, MCAP)
    if name is not None:
        _mirror(resolved, bridge, SENSOR_MCAP, resolved.components[name].params["path"])


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
