"""ROS 2 services on rmw_cyclonedds' wire conventions: what ``ros2 service call /sim/reset std_srvs/srv/Empty``
on a ROS 2 node with rmw_cyclonedds_cpp talks to.

A service ``/<name>`` of type ``pkg/srv/Type`` is two DDS topics (rmw_cyclonedds_cpp, rmw_node.cpp)::

    request   rq/<name>Request   <pkg>::srv::dds_::<Type>_Request_    client -> service
    reply     rr/<name>Reply     <pkg>::srv::dds_::<Type>_Response_   service -> client

QoS: rmw_qos_profile_services_default (reliable, volatile, keep last 10). Each
sample starts with rmw_cyclonedds' request header (``cdds_request_header_t``,
:func:`.messages.service_types`): ``guid``, the client's id (the instance
handle of its request writer; the client keeps only replies that carry it)
and ``seq``, the client's sequence number. The service answers with the same
two values, so the client matches reply to request.

Pairing: rmw_cyclonedds puts ``serviceid=<id>;`` in the USER_DATA of a service's
reader and writer (a client's: ``clientid=<id>;``). A client counts the
service available when its request writer has matched a reader and its reply
reader a writer of one service id (without ids: any match). Before replying,
the service waits (at most :data:`REPLY_WAIT_S`, as rmw_cyclonedds does) until its
reply writer has matched the reader of the requesting client, found by the
``clientid`` of the request's writer: a reliable but volatile reply sent earlier
would never reach it. A client that does not identify itself is answered at once.
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import time

from .transport import DEFAULT_QOS, TopicQos, dds_service_names

#: wall s a reply waits for the requesting client's reply reader to be matched (rmw_cyclonedds: 100 ms)
REPLY_WAIT_S = 0.1
_IDS = itertools.count(1)


def user_data_key(qos, key: str) -> str | None:
    """The value of ``key`` in an endpoint's USER_DATA (``k1=v1;k2=v2;``), or None."""
    from cyclonedds.qos import Policy

    try:
        data = qos[Policy.Userdata].data
    except (KeyError, TypeError, AttributeError):
        return None
    for item in bytes(data).decode(errors="replace").split(";"):
        k, sep, v = item.partition("=")
        if sep and k == key:
            return v
    return None


@dataclasses.dataclass(frozen=True)
class Call:
    """One request taken: its message, the header to answer with, and the writer it came from."""

    request: object
    guid: int
    seq: int
    writer: int             # instance handle of the client's request writer (to find its reply reader)


class ServiceServer:
    """Service ``name`` of type ``srv`` ('std_srvs/srv/Empty') on a :class:`.transport.Ros2Participant`."""

    def __init__(self, dds, name: str, srv: str):
        from .messages import service_types

        self.name, self.srv = name, srv
        self.Request, self.Response = service_types(srv)
        rq, rr = dds_service_names(name)
        self.service_id = f"{os.getpid() & 0xff:x}.{next(_IDS):x}.{id(self) & 0xffffff:x}"
        qos = TopicQos(reliable=DEFAULT_QOS.reliable, depth=DEFAULT_QOS.depth,
                       user_data=f"serviceid={self.service_id};")
        self.reader = dds.reader(name, self.Request, qos, dds_name=rq)
        self.writer = dds.writer(name, self.Response, qos, dds_name=rr)
        self.replies = self.unanswered = 0

    def take(self) -> list[Call]:
        """Every request that arrived, in order."""
        out = []
        for m in self.reader.take(N=64):
            if isinstance(m, self.Request):
                info = getattr(m, "sample_info", None)
                out.append(Call(m, int(m.header_guid), int(m.header_seq),
                                int(getattr(info, "publication_handle", 0) or 0)))
        return out

    def reply(self, call: Call, **fields) -> bool:
        """Answer ``call`` with a response of these fields; False when the client's reply reader was not
        matched in time (counted in ``unanswered``; the client then times out, as with rmw_cyclonedds)."""
        if not self._client_reader_matched(call):
            self.unanswered += 1
            return False
        self.writer.write(self.Response(header_guid=call.guid, header_seq=call.seq, **fields))
        self.replies += 1
        return True

    def _client_reader_matched(self, call: Call) -> bool:
        try:
            pub = self.reader.get_matched_publication_data(call.writer) if call.writer else None
        except Exception:
            pub = None
        client = user_data_key(pub.qos, "clientid") if pub is not None else None
        if client is None:
            return True                  # a client without an id (or gone): answer, as rmw_cyclonedds does
        end = time.monotonic() + REPLY_WAIT_S
        while True:
            for h in self.writer.get_matched_subscriptions():
                try:
                    sub = self.writer.get_matched_subscription_data(h)
                except Exception:
                    continue
                if sub is not None and user_data_key(sub.qos, "clientid") == client:
                    return True
            if time.monotonic() >= end:
                return False
            time.sleep(0.005)
