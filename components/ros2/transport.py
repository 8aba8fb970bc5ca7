"""A DDS participant on ROS 2's conventions: what makes snakesim's topics visible to any ROS 2 node.

No ROS installation: Cyclone DDS (``cyclonedds``), the RMW that ROS 2 ships by
default in several distributions, speaking the same RTPS wire protocol.
ROS 2's conventions on top of DDS:

    topic names     ``rt/<name>`` for topic ``/<name>``; ``rq/<name>Request``, ``rr/<name>Reply`` for
                    service ``/<name>`` (:mod:`.services`)
    type names      ``<pkg>::msg::dds_::<Type>_`` (:mod:`.messages`)
    encoding        plain CDR (XCDR1), as rmw_cyclonedds and rmw_fastrtps write it
    QoS             the profiles of rclcpp/tf2 (:data:`QOS`): default (reliable, keep last 10,
                    volatile); ``/clock`` as rclcpp::ClockQoS (best effort, keep last 1);
                    ``/tf`` as tf2's DynamicBroadcasterQoS (reliable, keep last 100);
                    ``/tf_static`` and ``/robot_description`` latched (reliable, transient local,
                    keep last 1), so a node that starts later still gets them

Malformed input: a sample whose CDR does not decode as the topic's type (truncated, a sequence longer than
the data, a string without its terminator: another type under the same name, a broken writer) is dropped
by the reader (:class:`Ros2Reader`), never raised into the run: logged as a warning on ``snakesim.ros2``
naming the topic and the decoder's reason (rate-limited as rejections are, :mod:`.rejections`), counted
on the reader (``dropped``) and handed to the reader's ``on_malformed(topic, reason)``, by which the
command sources count it with their rejections.

Node graph: a process has one DDS participant per domain (:class:`SharedParticipant`; each
:class:`Ros2Participant` is a handle onto it, as rclcpp has one participant per context), which announces
the endpoints of every component as one ROS node ``/snakesim`` on ``ros_discovery_info``
(:meth:`Ros2Participant.announce`, :mod:`.node_graph`), so ``ros2 node list`` shows exactly one node.

Network: by default traffic stays on this machine. Cyclone is configured
(its XML, per domain, given to ``Domain``; nothing in the environment is read
or changed) to use the loopback interface only, with multicast off and
unicast discovery to 127.0.0.1, so nothing is sent to any other host and no
multicast leaves the machine. ``interface`` names another interface or
address (e.g. ``eth0``) to talk to a robot computer; then multicast
discovery is on as ROS 2 has it. The domain id defaults to ``ROS_DOMAIN_ID``
(else 0), as for ROS 2 nodes.

A ROS 2 node on the same machine must use the same setting to see the topics,
e.g. ``CYCLONEDDS_URI`` with :func:`cyclone_xml`'s text (the README gives it);
``ros2 topic list`` then shows them.
"""

from __future__ import annotations

import dataclasses

import os
import threading
import weakref
from dataclasses import dataclass
from typing import Literal

from pydantic import Field

from snakesim.framework import Params

from .node_graph import NODE, TOPIC as DISCOVERY_TOPIC, NodeEntities

LOOPBACK = "127.0.0.1"
#: highest participant index a loopback (unicast) discovery probes; ~this many processes per domain per host
MAX_PARTICIPANTS = 32


def default_domain() -> int:
    """ROS_DOMAIN_ID, else 0 (ROS 2's rule)."""
    v = os.environ.get("ROS_DOMAIN_ID", "").strip()
    return int(v) if v.isdigit() else 0


def cyclone_xml(interface: str = LOOPBACK, domain_id: int | str = "any") -> str:
    """Cyclone DDS configuration: loopback only, no multicast (default), or ``interface`` with multicast."""
    local = interface in (LOOPBACK, "lo", "localhost")
    iface = f'<NetworkInterface address="{LOOPBACK}"/>' if local else (
        f'<NetworkInterface address="{interface}"/>' if interface[:1].isdigit() else f'<NetworkInterface name="{interface}"/>')
    discovery = (f"<Discovery><ParticipantIndex>auto</ParticipantIndex>"
                 f"<MaxAutoParticipantIndex>{MAX_PARTICIPANTS}</MaxAutoParticipantIndex>"
                 f'<Peers><Peer address="{LOOPBACK}"/></Peers></Discovery>') if local else ""
    multicast = "<AllowMulticast>false</AllowMulticast>" if local else ""
    return (f'<CycloneDDS><Domain id="{domain_id}"><General><Interfaces>{iface}</Interfaces>{multicast}'
            f"</General>{discovery}</Domain></CycloneDDS>")


@dataclass(frozen=True)
class TopicQos:
    reliable: bool = True
    depth: int = 10
    transient_local: bool = False
    user_data: str = ""          # USER_DATA QoS (rmw_cyclonedds: "serviceid=…;" on a service's endpoints)

    def qos(self):
        from cyclonedds.qos import Policy, Qos
        from cyclonedds.util import duration

        policies = [Policy.Reliability.Reliable(duration(milliseconds=100)) if self.reliable
                    else Policy.Reliability.BestEffort,
                    Policy.History.KeepLast(self.depth),
                    Policy.Durability.TransientLocal if self.transient_local else Policy.Durability.Volatile,
                    Policy.DataRepresentation(use_cdrv0_representation=True)]
        if self.user_data:
            policies.append(Policy.Userdata(self.user_data.encode()))
        return Qos(*policies)


DEFAULT_QOS = TopicQos()                                     # rclcpp::QoS(10): SystemDefaultsQoS with depth 10
CLOCK_QOS = TopicQos(reliable=False, depth=1)                # rclcpp::ClockQoS
TF_QOS = TopicQos(depth=100)                                 # tf2_ros::DynamicBroadcasterQoS
LATCHED_QOS = TopicQos(depth=1, transient_local=True)        # tf2_ros::StaticBroadcasterQoS, robot_description

#: QoS by topic; others: DEFAULT_QOS
QOS = {"/clock": CLOCK_QOS, "/tf": TF_QOS, "/tf_static": LATCHED_QOS, "/robot_description": LATCHED_QOS}


def dds_topic_name(topic: str) -> str:
    """'/joint_states' -> 'rt/joint_states' (ROS 2's topic prefix)."""
    name = topic.lstrip("/")
    if not name or any(c.isspace() for c in name):
        raise ValueError(f"ROS 2 topic name '{topic}' is empty or has white space")
    return f"rt/{name}"


def dds_service_names(service: str) -> tuple[str, str]:
    """'/sim/reset' -> ('rq/sim/resetRequest', 'rr/sim/resetReply'): a service's request and reply topics."""
    name = dds_topic_name(service)[3:]
    return f"rq/{name}Request", f"rr/{name}Reply"


#: this process's Cyclone domains by id: (weak reference to the Domain, its interface). Cyclone allows one
#: Domain object per id per process, so the publisher, the command source and a test's own participant
#: share it; it is deleted when the last participant holding it goes.
_DOMAINS: dict[int, tuple[weakref.ref, str]] = {}
_DOMAINS_LOCK = threading.Lock()


def shared_domain(domain_id: int, interface: str = LOOPBACK):
    """The process's Cyclone ``Domain`` for ``domain_id`` (created with :func:`cyclone_xml` on first use).
    An error when it exists with another interface (one configuration per domain per process)."""
    from cyclonedds.domain import Domain

    with _DOMAINS_LOCK:
        ref, iface = _DOMAINS.get(domain_id, (None, None))
        dom = ref() if ref is not None else None
        if dom is not None:
            if iface != interface:
                raise ValueError(f"ROS 2 domain {domain_id} is already open in this process on interface "
                                 f"'{iface}', not '{interface}'")
            return dom
        dom = Domain(domain_id, cyclone_xml(interface, domain_id))
        _DOMAINS[domain_id] = (weakref.ref(dom), interface)
        return dom


def _delete(entity) -> None:
    """Delete a DDS entity now (as its garbage collection would), once."""
    from cyclonedds.core import Entity

    try:
        Entity.__del__(entity)
    except Exception:              # noqa: BLE001 - already gone with its participant
        pass


class SharedParticipant:
    """The process's one DDS participant on a domain (rclcpp has one per context): every
    :class:`Ros2Participant` of the process on that domain is a handle onto it, so the process is one
    participant in DDS discovery and one node, ``/snakesim``, in ``ros2 node list``; deleted when the last
    handle goes. It owns the ``ros_discovery_info`` writer and publishes, on each change, one
    ParticipantEntitiesInfo: its gid and, per announced node name, the readers and writers of every handle
    that announced it (:mod:`.node_graph`)."""

    def __init__(self, domain_id: int, interface: str):
        from cyclonedds.domain import DomainParticipant

        self.domain_id, self.interface = domain_id, interface
        self.domain = shared_domain(domain_id, interface)
        self.participant = DomainParticipant(domain_id)
        self._lock = threading.RLock()
        self._announced: dict[int, tuple[str, list]] = {}      # id(handle) -> (node, its entity list)
        self._writer = None
        self._info: NodeEntities | None = None
        self._topic = None
        self.handles: "weakref.WeakSet" = weakref.WeakSet()     # open Ros2Participant handles

    def nodes(self) -> dict[str, tuple[list, list]]:
        """Announced node name -> (readers, writers) of all handles that announced it."""
        from cyclonedds.sub import DataReader

        out: dict[str, tuple[list, list]] = {}
        for node, entities in self._announced.values():
            readers, writers = out.setdefault(node, ([], []))
            for e in entities:
                (readers if isinstance(e, DataReader) else writers).append(e)
        return out

    def announce(self, handle, node: str, entities: list, distro: str) -> None:
        from cyclonedds.pub import DataWriter
        from cyclonedds.topic import Topic

        with self._lock:
            if self._info is None:
                self._info = NodeEntities(node, distro=distro)
                self._topic = Topic(self.participant, DISCOVERY_TOPIC, self._info.Info)
                self._writer = DataWriter(self.participant, self._topic, LATCHED_QOS.qos())
            elif self._info.distro != distro:
                raise ValueError(f"ROS 2 domain {self.domain_id}: the node graph is announced with the "
                                 f"{self._info.distro} layout in this process, not {distro}")
            self._announced[id(handle)] = (node, entities)
            self._publish()

    def withdraw(self, handle) -> None:
        """``handle`` closes: its endpoints leave the next announcement. Not re-announced at once: the run's
        components close one after the other at its end, and gids of deleted endpoints in the last
        announcement are harmless (rmw_dds_common looks each up among the endpoints DDS discovered)."""
        with self._lock:
            self._announced.pop(id(handle), None)

    def _publish(self) -> None:
        self._writer.write(self._info.nodes_message(self.participant, self.nodes()))


#: the process's shared participants by domain id (weakly: deleted with their last handle)
_PARTICIPANTS: dict[int, weakref.ref] = {}


def shared_participant(domain_id: int, interface: str = LOOPBACK) -> SharedParticipant:
    """The process's :class:`SharedParticipant` on ``domain_id`` (created on first use)."""
    with _DOMAINS_LOCK:
        ref = _PARTICIPANTS.get(domain_id)
        shared = ref() if ref is not None else None
        if shared is not None and shared.interface == interface:
            return shared
    if shared is not None:                 # the same error shared_domain gives
        shared_domain(domain_id, interface)
    shared = SharedParticipant(domain_id, interface)
    with _DOMAINS_LOCK:
        _PARTICIPANTS[domain_id] = weakref.ref(shared)
    return shared


class Ros2Participant:
    """One DDS participant on ``domain_id`` with ROS 2 topic, type and QoS conventions.

    ``writer(topic, MsgType)`` and ``reader(topic, MsgType)`` make endpoints;
    :meth:`close` (or the context manager) releases them. Cyclone's domain is
    created with :func:`cyclone_xml` (:func:`shared_domain`: one per id per
    process, shared by every participant on it), so the process's
    CYCLONEDDS_URI is not used for it.
    """

    def __init__(self, domain_id: int | None = None, interface: str = LOOPBACK):
        self.domain_id = default_domain() if domain_id is None else int(domain_id)
        if not 0 <= self.domain_id <= 232:
            raise ValueError(f"ROS 2 domain id must be 0..232, got {self.domain_id}")
        self.interface = interface
        self._shared = shared_participant(self.domain_id, interface)
        self._domain = self._shared.domain
        self.participant = self._shared.participant
        self._topics: dict[str, object] = {}
        self._entities: list = []
        self._announcer = None
        #: this handle's ROS 2 topic endpoints (not services): rows of :mod:`.qos_table`
        self.endpoints: list[tuple] = []
        self._shared.handles.add(self)

    def _describe(self, direction: str, topic: str, msg_type, q: "TopicQos", dds_name: str | None) -> None:
        if dds_name is not None:                  # a service's rq/rr topic, ros_discovery_info
            return
        from .qos_table import row

        pkg, kind, _, name = (getattr(msg_type, "__idl_typename__", "") or "?::?::?::?").split("::")[:4]
        row_ = row(topic, direction, f"{pkg}/{kind}/{name.rstrip('_')}", q)
        if row_ not in self.endpoints:
            self.endpoints.append(row_)

    def shared_endpoints(self) -> list[tuple]:
        """The endpoint rows of every open handle of this process's participant on this domain."""
        return [r for h in list(self._shared.handles) for r in h.endpoints] if self._shared else list(self.endpoints)

    def _topic(self, topic: str, msg_type, dds_name: str | None = None):
        from cyclonedds.topic import Topic

        name = dds_name or dds_topic_name(topic)
        t = self._topics.get(name)
        if t is None:
            t = self._topics[name] = Topic(self.participant, name, msg_type)
        return t

    def writer(self, topic: str, msg_type, qos: TopicQos | None = None, dds_name: str | None = None):
        """A writer on ROS 2 topic ``topic`` (DDS ``rt/…``), or on the DDS topic ``dds_name`` as given
        (a service's ``rq/``/``rr/`` topics, ``ros_discovery_info``)."""
        from cyclonedds.pub import DataWriter

        q = qos or QOS.get(topic, DEFAULT_QOS)
        w = DataWriter(self.participant, self._topic(topic, msg_type, dds_name), q.qos())
        self._entities.append(w)
        self._describe("pub", topic, msg_type, q, dds_name)
        return w

    def reader(self, topic: str, msg_type, qos: TopicQos | None = None, dds_name: str | None = None,
               on_malformed=None):
        """A reader (:class:`Ros2Reader`: malformed samples dropped, logged and passed to ``on_malformed``)."""
        q = qos or QOS.get(topic, DEFAULT_QOS)
        r = _reader_class()(self.participant, self._topic(topic, msg_type, dds_name), q.qos())
        self._describe("sub", topic, msg_type, q, dds_name)
        r.ros_topic = dds_name or topic
        # a bound method is held weakly: the reader must not keep its run's state (which closes it) alive
        r.on_malformed = weakref.WeakMethod(on_malformed) if hasattr(on_malformed, "__self__") else (
            (lambda f=on_malformed: f) if on_malformed is not None else None)
        self._entities.append(r)
        return r

    def announce(self, node: str = "snakesim", distro: str = "humble") -> None:
        """Publish this participant's readers and writers as (part of) ROS node ``/<node>`` on
        ``ros_discovery_info`` (:mod:`.node_graph`: ``ros2 node list`` shows it); call again after adding
        endpoints. Every handle of the process's DDS participant (:func:`shared_participant`) that announces
        the same node adds its endpoints to that one node, as one rclcpp node with many publishers; the
        announcement's own writer (latched, as rmw_cyclonedds makes it) is not one of the node's."""
        self._announcer = node
        self._shared.announce(self, node, self._entities, distro)

    def close(self) -> None:
        """Delete this handle's readers, writers and topics (the shared participant stays while another
        handle holds it) and take them out of the node-graph announcement."""
        shared, entities, topics = self._shared, list(self._entities), list(self._topics.values())
        self._announcer = None
        self._entities.clear()
        self._topics.clear()
        if shared is not None:
            shared.handles.discard(self)
            shared.withdraw(self)
            for e in entities + topics:
                _delete(e)
        self._shared = None
        self.endpoints = []
        self.participant = None
        self._domain = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class MalformedSample(ValueError):
    """A sample whose CDR did not decode as its topic's type (the reader dropped it)."""


#: dropped malformed samples' log: reason key -> [wall s of the last line, dropped since]
_MALFORMED_SEEN: dict[str, list] = {}
MALFORMED_LOG_EVERY = 1.0          # wall s between two lines for one reason


def _log_malformed(topic: str, reason: str) -> None:
    """Warn that ``topic`` dropped a malformed sample, at most once per reason per MALFORMED_LOG_EVERY s."""
    import logging
    import time

    from .rejections import reason_key

    text = f"{topic}: dropped a malformed sample: {reason}"
    key, now = reason_key(text), time.monotonic()
    seen = _MALFORMED_SEEN.get(key)
    if seen is not None and now - seen[0] < MALFORMED_LOG_EVERY:
        seen[1] += 1
        return
    if len(_MALFORMED_SEEN) > 1000:
        _MALFORMED_SEEN.clear()
    more = seen[1] if seen is not None else 0
    _MALFORMED_SEEN[key] = [now, 0]
    logging.getLogger("snakesim.ros2").warning(
        "%s%s", text, f" (and {more} more for this reason since the last line)" if more else "")


_READER_CLASS = None


def _reader_class():
    """:class:`Ros2Reader`, defined on first use (cyclonedds is imported lazily)."""
    global _READER_CLASS
    if _READER_CLASS is None:
        from cyclonedds._clayer import ddspy_take
        from cyclonedds.core import DDSException, InstanceState, SampleState, ViewState
        from cyclonedds.internal import InvalidSample
        from cyclonedds.sub import DataReader

        class Ros2Reader(DataReader):
            """A DataReader whose :meth:`take` decodes sample by sample and drops (logs, counts, reports) one
            that does not decode, instead of raising and losing the batch."""

            ros_topic = ""
            on_malformed = None
            dropped = 0

            def take(self, N: int = 1, condition=None, instance_handle=None):
                if condition is not None or instance_handle is not None:
                    return super().take(N, condition, instance_handle)
                ret = ddspy_take(self._ref, SampleState.Any | ViewState.Any | InstanceState.Any, N)
                if type(ret) is int:
                    raise DDSException(ret, f"Occurred while taking data in {self!r}")
                dtype = self._topic.data_type
                out = []
                for data, info in ret:
                    try:
                        if info.valid_data:
                            m = dtype.deserialize(data)
                            m.sample_info = info
                        else:
                            m = InvalidSample(dtype.deserialize_key(data), info)
                    except Exception as e:          # noqa: BLE001 - any decoder error is a malformed sample
                        self.dropped += 1
                        reason = f"{len(data)} bytes do not decode as {dtype.__name__}: {type(e).__name__}: {e}"
                        _log_malformed(self.ros_topic, reason)
                        report = self.on_malformed() if self.on_malformed is not None else None
                        if report is not None:
                            report(self.ros_topic, reason)
                        continue
                    out.append(m)
                return out

        _READER_CLASS = Ros2Reader
    return _READER_CLASS


def arrivals_waitset(dds: "Ros2Participant", readers) -> "Arrivals":
    """Whether any of ``readers`` holds a sample (:class:`Arrivals`), for components that poll each tick."""
    return Arrivals(dds, readers)


class Arrivals:
    """``arrivals()``: True when one of some readers holds a sample not yet read; the per-tick question of
    every polling command source, asked without blocking and without decoding anything.

    Two ways, whichever costs less for this many readers (measured in a run, between steps: each C call
    costs more there than in a loop, its memory having left the caches):

    few readers   a read of at most one not-yet-read sample per reader through cyclonedds' C extension
                  (``ddspy_read``; ~0.3 µs each, the GIL kept: no ctypes call, no thread switch)
    many          a WaitSet with a ReadCondition per reader, asked with one ctypes call of
                  ``dds_waitset_wait(ws, NULL, 0, 0)`` (~1-2 µs whatever the count)

    A sample read here is marked read, not taken: the caller takes every sample (any state) when this
    says True."""

    FEW = 4              # readers up to which the reads are cheaper than the waitset's one ctypes call

    def __init__(self, dds: "Ros2Participant", readers):
        import ctypes as ct

        from cyclonedds._clayer import ddspy_read
        from cyclonedds.core import Entity, InstanceState, ReadCondition, SampleState, ViewState, WaitSet

        readers = list(readers)
        self.waitset = self.conditions = None
        if len(readers) <= self.FEW:
            self._refs = tuple(r._ref for r in readers)
            self._read, self._mask = ddspy_read, int(SampleState.NotRead)
            return
        self._refs = None
        self.waitset = ws = WaitSet(dds.participant)
        # held here: a condition collected by Python would be deleted in DDS
        self.conditions = [ReadCondition(r, SampleState.Any | ViewState.Any | InstanceState.Any) for r in readers]
        for c in self.conditions:
            ws.attach(c)
        fn = Entity._dll_handle["dds_waitset_wait"]       # item access: our own function object, not cyclonedds'
        fn.argtypes = [ct.c_int32, ct.c_void_p, ct.c_size_t, ct.c_int64]
        fn.restype = ct.c_int32
        self._wait, self._ref = fn, ws._ref

    def __call__(self) -> bool:
        refs = self._refs
        if refs is not None:
            read, mask = self._read, self._mask
            for ref in refs:
                if read(ref, mask, 1):       # [] when none; a sample, or an error code the take then raises
                    return True
            return False
        ret = self._wait(self._ref, None, 0, 0)
        if ret < 0:
            from cyclonedds.core import DDSException

            raise DDSException(ret, "checking the readers' waitset for arrivals")
        return ret > 0


@dataclasses.dataclass(eq=False)
class BridgeRun:
    """A topic bridge's run state (``u.cache``): message templates, the participant (or the MCAP file of
    its mirror) and writers, messages published; an MCAP mirror's writer and the stamp it logs at."""

    templates: tuple | None = None
    dds: object = None
    writers: dict = dataclasses.field(default_factory=dict)
    published: int = 0
    finalizer: object = None
    writer: object = None          # the MCAP writer (McapChannel reads run.writer and run.now_ns)
    now_ns: int = 0

    def close(self) -> None:
        if self.finalizer is not None:
            self.finalizer()
        self.finalizer, self.dds = None, None


class ClosedAfterRun:
    """Mixin of the ROS 2 components: what their run opened (``u.cache.close()``: a DDS participant and its
    endpoints, a share of an MCAP file) is closed once the run has ended (Component.after_run), so a
    recording is complete when ``run`` returns and a next run opens afresh."""

    def after_run(self, u) -> None:
        u.cache.close()


class DdsEndpoint(Params):
    """Where a ROS 2 component talks: the DDS domain and network interface, and how it shows in ROS 2's node
    graph (one definition for all)."""

    domain_id: int | None = Field(None, ge=0, le=232, description="DDS domain (default: ROS_DOMAIN_ID, else 0)")
    interface: str = Field(LOOPBACK, description="network interface name or address; 127.0.0.1 (default): "
                                                 "this machine only, no multicast")
    node_graph: bool = Field(True, description="announce the component's endpoints as a ROS node on "
                                               "ros_discovery_info (ros2 node list)")
    ros_distro: Literal["humble", "jazzy"] = Field("humble", description="whose rmw_dds_common Gid layout the "
                                                   "node-graph announcement uses (Humble: 24 bytes; Iron, "
                                                   "Jazzy: 16)")

    def announce(self, dds: "Ros2Participant", component: str | None = None) -> None:
        """Announce ``dds``'s endpoints as part of the process's one ROS node ``/snakesim``
        (:data:`.node_graph.NODE`) when ``node_graph`` is on. ``component`` (e.g. ``snakesim_commands``)
        names the part for the reader; every component of the process shows as the one node."""
        if self.node_graph:
            dds.announce(NODE, self.ros_distro)
