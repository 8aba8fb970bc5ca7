"""A separate ROS 2 node (cyclonedds and the standard message types only) that sends one JointTrajectory.

    python trajectory_peer.py DOMAIN JOINT SECONDS  ->  {"ready": true} at once, then one JSON line

It waits for /joint_states, then sends on /joint_commands (trajectory_msgs/JointTrajectory, unstamped:
"now") JOINT to TARGETS at TIMES (time_from_start, s) and records JOINT's position from /joint_states
(sim-time stamps) until the run is over: {"sent_at": sim s of the last /joint_states before sending,
"joint": [[t, q], ...], "names": [...]}.
"""

import json
import sys
import time

from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from snakesim.components.ros2.messages import Duration, JointState, JointTrajectory, JointTrajectoryPoint

XML = ('<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
       '<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>'
       '<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
       '</Discovery></Domain></CycloneDDS>')
TARGETS = [(0.3, 0.0), (0.3, 0.0)]    # (position rad, velocity rad/s) per point
TIMES = [0.6, 1.0]                    # s, time_from_start
SEND_AFTER = 0.3                      # s of sim time after the first /joint_states


def main(domain: int, joint: str, seconds: float) -> None:
    dom = Domain(domain, XML)  # noqa: F841  (kept alive)
    dp = DomainParticipant(domain)
    qos = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10000))
    js = DataReader(dp, Topic(dp, "rt/joint_states", JointState), qos)
    w = DataWriter(dp, Topic(dp, "rt/joint_commands", JointTrajectory),
                   Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10)))
    print(json.dumps({"ready": True}), flush=True)
    out = {"sent_at": None, "joint": [], "names": None}
    first, last_data, k = None, None, None
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        got = False
        for m in js.take(N=1000):
            if not isinstance(m, JointState):
                continue
            got = True
            t = m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec
            if k is None:
                out["names"] = list(m.name)
                k = out["names"].index(joint)
            out["joint"].append((t, m.position[k]))
            first = t if first is None else first
        if out["joint"] and out["sent_at"] is None and out["joint"][-1][0] >= first + SEND_AFTER:
            while not w.get_matched_subscriptions() and time.monotonic() < end:
                time.sleep(0.005)
            pts = [JointTrajectoryPoint(positions=[p], velocities=[v],
                                        time_from_start=Duration(sec=int(tf), nanosec=int(round(tf % 1 * 1e9))))
                   for (p, v), tf in zip(TARGETS, TIMES)]
            w.write(JointTrajectory(joint_names=[joint], points=pts))
            out["sent_at"] = out["joint"][-1][0]
        if got:
            last_data = time.monotonic()
        elif last_data is not None and time.monotonic() - last_data > 1.5:
            break                                   # the run is over
        time.sleep(0.005)
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), sys.argv[2], float(sys.argv[3]))
