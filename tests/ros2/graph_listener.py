"""A separate process reading ROS 2's node graph as rmw_cyclonedds does, with cyclonedds alone: the
``ros_discovery_info`` topic (rmw_dds_common/msg/ParticipantEntitiesInfo, Humble's definition from rosbags)
and DDS's own publication discovery (DCPSPublication), on loopback.

    python graph_listener.py DOMAIN SECONDS  ->  {"ready": true}, then once the run is gone (or SECONDS):
        {"nodes": [{"participant", "namespace", "name", "readers", "writers"}],   gids as hex
         "publications": [{"topic", "key", "participant"}]}                      GUIDs as hex
"""

import json
import sys
import time

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from snakesim.components.ros2.messages import ros_type

XML = ('<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
       '<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>'
       '<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
       '</Discovery></Domain></CycloneDDS>')


def main(domain, seconds):
    dom = Domain(domain, XML)  # noqa: F841  (kept alive)
    dp = DomainParticipant(domain)
    Info = ros_type("rmw_dds_common/msg/ParticipantEntitiesInfo")
    # rmw_cyclonedds' own reader of it: reliable, transient local, keep all
    info = DataReader(dp, Topic(dp, "ros_discovery_info", Info),
                      Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepAll,
                          Policy.Durability.TransientLocal, Policy.DataRepresentation(use_cdrv0_representation=True)))
    pubs = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
    print(json.dumps({"ready": True}), flush=True)
    nodes, publications = {}, {}
    end, last = time.monotonic() + seconds, None
    while time.monotonic() < end:
        got = False
        for m in info.take(N=100):
            if isinstance(m, Info):
                got = True
                part = bytes(m.gid.data).hex()
                for n in m.node_entities_info_seq:
                    nodes[(part, n.node_name)] = {
                        "participant": part, "namespace": n.node_namespace, "name": n.node_name,
                        "readers": [bytes(g.data).hex() for g in n.reader_gid_seq],
                        "writers": [bytes(g.data).hex() for g in n.writer_gid_seq]}
        for p in pubs.take(N=100):
            if getattr(p, "topic_name", None) and p.key.hex not in publications:   # not a disposal
                got = True
                publications[p.key.hex] = {"topic": p.topic_name, "key": p.key.hex,
                                           "participant": p.participant_key.hex}
        if got:
            last = time.monotonic()
        elif last is not None and nodes and time.monotonic() - last > 3.0:
            break
        time.sleep(0.02)
    print(json.dumps({"nodes": list(nodes.values()), "publications": list(publications.values())}), flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), float(sys.argv[2]))
