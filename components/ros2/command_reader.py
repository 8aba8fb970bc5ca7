"""The per-run state of a ROS 2 command source that reads one topic (tether and gait commands): the DDS
reader, opened on the source's first tick, and its counts; closed with the run (or at interpreter exit)."""

from __future__ import annotations

import dataclasses
import weakref

from .rejections import RejectionLog


@dataclasses.dataclass(eq=False)
class CommandReaderRun:
    """One run's state (``u.cache``): the DDS reader (opened on the first tick) and counts."""

    started: bool = False
    dds: object = None
    reader: object = None
    rejected: int = 0
    applied: int = 0
    malformed_count: int = 0
    log: RejectionLog | None = None
    finalizer: object = None

    def open(self, endpoint, topic: str, msg_type, node: str) -> None:
        """Open a participant on ``endpoint``'s (DdsEndpoint params) domain and interface, a reader of
        ``topic``, and announce ``node`` on the ROS graph (:mod:`.node_graph`)."""
        from .transport import Ros2Participant

        dds = Ros2Participant(endpoint.domain_id, endpoint.interface)
        self.reader = dds.reader(topic, msg_type, on_malformed=self.malformed)
        self.dds = dds
        endpoint.announce(dds, node)
        self.finalizer = weakref.finalize(self, dds.close)

    def malformed(self, topic: str, reason: str) -> None:
        """A sample the transport dropped as malformed (it logged it, naming topic and reason): counted with
        the rejections (the source's ``rejected`` output shows it from its next rejection)."""
        self.rejected += 1
        self.malformed_count += 1
        if hasattr(self, "last_reason"):
            self.last_reason = f"{topic}: dropped a malformed sample: {reason}"

    def close(self) -> None:
        if self.finalizer is not None:
            self.finalizer()
        self.finalizer, self.dds, self.reader = None, None, None
