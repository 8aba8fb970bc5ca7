"""A separate ROS 2 client written against cyclonedds alone (no snakesim transport or service code): topics and
services as a ROS 2 node with rmw_cyclonedds_cpp would send them.

Types: snakesim.components.ros2.messages (checked against rosbags' standard definitions and std_srvs' .srv
text by tests/ros2/test_messages.py). The DDS configuration is spelled out here: loopback only, no multicast.

    python sim_client.py DOMAIN SECONDS SCRIPT_JSON  ->  JSON lines on stdout: {"ready": true} at once, then
                                                         one object with what it did and saw

SCRIPT_JSON is a list of steps, each done in turn once /clock has reached its ``at`` (s of sim time):

    {"at": 0.2, "topic": "/sim/reset", "type": "Empty", "msg": {}}
    {"at": 0.3, "service": "/sim/reset", "srv": "std_srvs/srv/Empty", "request": {}}
    {"at": 0.4, "sleep": 0.5}                        (wall s, reading /clock)

A message is built from nested dicts by field name (a list of dicts for a sequence of messages). A service
call is made as rmw_cyclonedds makes it: a request writer on rq/<name>Request and a reply reader on
rr/<name>Reply with USER_DATA "clientid=<id>;", used once the service is available (its request reader and
reply writer matched, with one serviceid); the request carries the header (guid: the request writer's
instance handle, seq: 1, 2, …), and the reply kept is the one whose header echoes both.

Output: {"clock": [[wall s, ns], ...] every /clock received, "steps": [{"wall", "clock_ns", ...}], ...}.
"""

import dataclasses
import json
import sys
import time

from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from snakesim.components.ros2 import messages as M

XML = ('<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
       '<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>'
       '<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
       '</Discovery></Domain></CycloneDDS>')


def qos(user_data=None):
    """ROS 2's default (and services') QoS: reliable, keep last 10, volatile, plain CDR."""
    p = [Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10),
         Policy.DataRepresentation(use_cdrv0_representation=True)]
    if user_data:
        p.append(Policy.Userdata(user_data.encode()))
    return Qos(*p)


def build(cls, spec):
    """A message of class ``cls`` from nested dicts."""
    kw = {}
    proto = cls()
    for f in dataclasses.fields(cls):
        if f.name not in spec:
            continue
        v, cur = spec[f.name], getattr(proto, f.name)
        if isinstance(v, dict):
            kw[f.name] = build(type(cur), v)
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            ann = cls.__annotations__[f.name]
            inner = getattr(ann, "subtype", None) or ann.__metadata__[0].subtype
            kw[f.name] = [build(inner, x) for x in v]
        else:
            kw[f.name] = v
    return cls(**kw)


def user_data(endpoint, key):
    try:
        data = bytes(endpoint.qos[Policy.Userdata].data).decode()
    except Exception:
        return None
    for item in data.split(";"):
        k, _, v = item.partition("=")
        if k == key:
            return v
    return None


class Client:
    """One service client, rmw_cyclonedds style."""

    count = 0

    def __init__(self, dp, name, srv):
        Client.count += 1
        self.Request, self.Response = M.service_types(srv)
        n = name.lstrip("/")
        cid = f"sim-client.{Client.count}"
        self.writer = DataWriter(dp, Topic(dp, f"rq/{n}Request", self.Request), qos(f"clientid={cid};"))
        self.reader = DataReader(dp, Topic(dp, f"rr/{n}Reply", self.Response), qos(f"clientid={cid};"))
        self.guid = self.writer.get_instance_handle() & 0xFFFF_FFFF_FFFF_FFFF     # a uint64, as rmw_cyclonedds
        self.seq = 0

    def available(self):
        """As rmw_service_server_is_available: a matched request reader and reply writer of one service."""
        readers = {user_data(self.writer.get_matched_subscription_data(h), "serviceid")
                   for h in self.writer.get_matched_subscriptions()}
        writers = {user_data(self.reader.get_matched_publication_data(h), "serviceid")
                   for h in self.reader.get_matched_publications()}
        return bool(readers & writers - {None})

    def call(self, request, timeout, on_idle):
        end = time.monotonic() + timeout
        while not self.available():
            if time.monotonic() > end:
                return {"error": "service not available"}
            on_idle()
            time.sleep(0.01)
        self.seq += 1
        self.writer.write(self.Request(header_guid=self.guid, header_seq=self.seq, **request))
        others = 0
        while time.monotonic() < end:
            for m in self.reader.take(N=10):
                if not isinstance(m, self.Response):
                    continue
                if m.header_guid == self.guid and m.header_seq == self.seq:
                    fields = {f.name: getattr(m, f.name) for f in dataclasses.fields(m)}
                    return {"reply": fields, "others": others}
                others += 1
            on_idle()
            time.sleep(0.002)
        return {"error": "no reply"}


def main(domain, seconds, script):
    dom = Domain(domain, XML)  # noqa: F841  (kept alive)
    dp = DomainParticipant(domain)
    clock = DataReader(dp, Topic(dp, "rt/clock", M.Clock),
                       Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(10000)))
    writers, clients = {}, {}
    for step in script:                              # endpoints first, so discovery is done before they are due
        if "topic" in step and step["topic"] not in writers:
            typ = getattr(M, step["type"])
            writers[step["topic"]] = DataWriter(dp, Topic(dp, "rt/" + step["topic"].lstrip("/"), typ), qos())
        if "service" in step and step["service"] not in clients:
            clients[step["service"]] = Client(dp, step["service"], step["srv"])
    out = {"clock": [], "steps": []}
    print(json.dumps({"ready": True}), flush=True)
    t0 = time.monotonic()
    last = [None]

    def read_clock():
        for m in clock.take(N=1000):
            if isinstance(m, M.Clock):
                ns = m.clock.sec * 1_000_000_000 + m.clock.nanosec
                out["clock"].append([time.monotonic() - t0, ns])
                last[0] = ns

    end = time.monotonic() + seconds
    deadline = end
    for step in script:
        while time.monotonic() < end and (last[0] is None or last[0] < step.get("at", 0) * 1e9):
            read_clock()
            time.sleep(0.002)
        if time.monotonic() >= end:
            out["steps"].append({"error": "run over before the step was due", **step})
            break
        done = {"wall": time.monotonic() - t0, "clock_ns": last[0]}
        if "topic" in step:
            w = writers[step["topic"]]
            while not w.get_matched_subscriptions() and time.monotonic() < end:
                time.sleep(0.005)
            w.write(build(getattr(M, step["type"]), step["msg"]))
        elif "service" in step:
            done.update(clients[step["service"]].call(step.get("request", {}), 10.0, read_clock))
            done["replied_wall"] = time.monotonic() - t0
            done["replied_clock_ns"] = last[0]
        elif "sleep" in step:
            stop = time.monotonic() + step["sleep"]
            while time.monotonic() < stop:
                read_clock()
                time.sleep(0.002)
        out["steps"].append(done)
    quiet = time.monotonic()
    n = len(out["clock"])
    while time.monotonic() < deadline and time.monotonic() - quiet < 1.5:   # until the run is over
        read_clock()
        if len(out["clock"]) != n:
            n, quiet = len(out["clock"]), time.monotonic()
        time.sleep(0.01)
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), float(sys.argv[2]), json.loads(sys.argv[3]))
