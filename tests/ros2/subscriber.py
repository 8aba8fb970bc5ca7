"""A separate ROS 2 subscriber written against cyclonedds alone (no snakesim transport code).

Types: snakesim.components.ros2.messages, which tests/ros2/test_messages.py checks against rosbags'
standard ROS 2 definitions. The DDS configuration is spelled out here: loopback only, no multicast.

    python subscriber.py DOMAIN SECONDS  ->  JSON on stdout once SECONDS have passed (or after the run's
                                             last /clock message and a quiet second)
"""

import json
import sys
import time

from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from snakesim.components.ros2.messages import Clock, JointState, String, TFMessage

XML = ('<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
       '<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>'
       '<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
       '</Discovery></Domain></CycloneDDS>')


def main(domain: int, seconds: float) -> None:
    dom = Domain(domain, XML)  # noqa: F841  (kept alive)
    dp = DomainParticipant(domain)
    deep = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10000))
    latched = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(1),
                  Policy.Durability.TransientLocal)
    clock = DataReader(dp, Topic(dp, "rt/clock", Clock), Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(10000)))
    js = DataReader(dp, Topic(dp, "rt/joint_states", JointState), deep)
    tf = DataReader(dp, Topic(dp, "rt/tf", TFMessage), deep)
    desc = DataReader(dp, Topic(dp, "rt/robot_description", String), latched)
    out = {"ready": True, "clock": [], "joint_states": [], "names": None, "tf_frames": None, "tf_count": 0,
           "description_chars": 0, "position_sample": None}
    print(json.dumps({"ready": True}), flush=True)
    end = time.monotonic() + seconds
    last_data = None
    while time.monotonic() < end:
        got = False
        for m in clock.take(N=1000):
            if not isinstance(m, Clock):
                continue      # InvalidSample: the writer went away
            out["clock"].append(m.clock.sec + 1e-9 * m.clock.nanosec)
            got = True
        for m in js.take(N=1000):
            if not isinstance(m, JointState):
                continue      # InvalidSample: the writer went away
            out["joint_states"].append(m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec)
            out["names"] = list(m.name)
            out["position_sample"] = list(m.position)
            got = True
        for m in tf.take(N=1000):
            if not isinstance(m, TFMessage):
                continue      # InvalidSample: the writer went away
            out["tf_count"] += 1
            out["tf_frames"] = [(t.header.frame_id, t.child_frame_id) for t in m.transforms][:3]
            got = True
        for m in desc.take(N=1):
            if not isinstance(m, String):
                continue      # InvalidSample: the writer went away
            out["description_chars"] = len(m.data)
        if got:
            last_data = time.monotonic()
        elif last_data is not None and time.monotonic() - last_data > 1.5:
            break                                   # the run is over
        time.sleep(0.01)
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), float(sys.argv[2]))
