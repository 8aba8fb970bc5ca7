"""A separate ROS 2 commander written against cyclonedds alone (no snakesim transport code).

Types: snakesim.components.ros2.messages, which tests/ros2/test_messages.py checks against rosbags'
standard ROS 2 definitions. The DDS configuration is spelled out here: loopback only, no multicast.

    python commander.py DOMAIN JOINT SECONDS  ->  JSON on stdout: {"ready": true} at once, then what it saw

It waits for /joint_states, commands JOINT to TARGET rad on /joint_command (sensor_msgs/JointState) and
watches it move; then turns gravity off (/enable_gravity false) and records the links' mean height from
/tf before and after; then sends each kind of malformed command and keeps listening, so the test sees
whether publishing went on; then pauses the run (/sim/pause true), reads the time it holds at from
/clock, steps it STEPS base steps (/sim/step, std_msgs/UInt32), reads /clock again and resumes it
(/sim/pause false). Everything it receives is timed by the messages' sim-time stamps.
"""

import json
import math
import sys
import time

from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from snakesim.components.ros2.messages import (Bool, Clock, Header, JointState, JointTrajectory,
                                               JointTrajectoryPoint, TFMessage, Time, UInt32)

XML = ('<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
       '<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>'
       '<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
       '</Discovery></Domain></CycloneDDS>')
TARGET = 0.4          # rad
SETTLE = 0.6          # s of sim time after the joint reaches its target before gravity goes off
WINDOW = 0.4          # s of sim time on each side of the toggle for the height fit
STEPS = 37            # base steps asked for while paused (not a multiple of the /clock period)
QUIET = 0.4           # wall s with /clock unchanged: the run is holding


def _stamp(h):
    return h.stamp.sec + 1e-9 * h.stamp.nanosec


def malformed(joint):
    """Each kind of malformed command: (kind, topic, message)."""
    return [
        ("unknown joint", "js", JointState(name=["no_such_joint"], position=[0.1])),
        ("nan", "js", JointState(name=[joint], position=[math.nan])),
        ("inf", "traj", JointTrajectory(joint_names=[joint], points=[JointTrajectoryPoint(positions=[math.inf])])),
        ("lengths", "traj", JointTrajectory(joint_names=[joint], points=[JointTrajectoryPoint(positions=[0.1, 0.2])])),
        ("stale", "js", JointState(header=Header(stamp=Time(sec=0, nanosec=1)), name=[joint], position=[-0.3])),
    ]


def main(domain: int, joint: str, seconds: float) -> None:
    dom = Domain(domain, XML)  # noqa: F841  (kept alive)
    dp = DomainParticipant(domain)
    default = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10))
    deep = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10000))
    js = DataReader(dp, Topic(dp, "rt/joint_states", JointState), deep)
    tf = DataReader(dp, Topic(dp, "rt/tf", TFMessage), deep)
    clock = DataReader(dp, Topic(dp, "rt/clock", Clock),
                       Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(1)))     # rclcpp::ClockQoS
    w = {"js": DataWriter(dp, Topic(dp, "rt/joint_command", JointState), default),
         "traj": DataWriter(dp, Topic(dp, "rt/joint_commands", JointTrajectory), default),
         "gravity": DataWriter(dp, Topic(dp, "rt/enable_gravity", Bool), default),
         "pause": DataWriter(dp, Topic(dp, "rt/sim/pause", Bool), default),
         "step": DataWriter(dp, Topic(dp, "rt/sim/step", UInt32), default)}
    print(json.dumps({"ready": True}), flush=True)
    out = {"matched": False, "sent_setpoint_at": None, "moved_at": None, "gravity_off_at": None,
           "malformed_at": None, "heights": [], "joint": [], "last_stamp": None, "stamps_after_malformed": 0,
           "paused_at_ns": None, "stepped_to_ns": None, "steps": STEPS, "resumed": False, "clock_after_resume_ns": None}
    clock_ns, clock_changed = None, time.monotonic()
    phase = None          # None, "pausing", "stepping", "resumed"
    end = time.monotonic() + seconds
    last_data = None
    k = None
    while time.monotonic() < end:
        got = False
        for m in js.take(N=1000):
            if not isinstance(m, JointState):
                continue
            got = True
            t = _stamp(m.header)
            if k is None:
                k = list(m.name).index(joint)
            out["joint"].append((t, m.position[k]))
            out["last_stamp"] = t
            if out["malformed_at"] is not None:
                out["stamps_after_malformed"] += 1
        for m in tf.take(N=1000):
            if not isinstance(m, TFMessage) or not m.transforms:
                continue
            got = True
            zs = [tr.transform.translation.z for tr in m.transforms]
            out["heights"].append((_stamp(m.transforms[0].header), sum(zs) / len(zs)))
        for m in clock.take(N=100):
            if isinstance(m, Clock):
                ns = m.clock.sec * 1_000_000_000 + m.clock.nanosec
                if clock_ns is None or ns > clock_ns:
                    clock_ns, clock_changed = ns, time.monotonic()
                    got = True
                    if phase == "resumed":
                        out["clock_after_resume_ns"] = ns
        quiet = time.monotonic() - clock_changed > QUIET
        if phase == "pausing" and quiet:
            out["paused_at_ns"] = clock_ns
            w["step"].write(UInt32(data=STEPS))
            phase, clock_changed = "stepping", time.monotonic()
        elif phase == "stepping" and quiet:
            out["stepped_to_ns"] = clock_ns
            w["pause"].write(Bool(data=False))
            phase, out["resumed"] = "resumed", True
        now = out["last_stamp"]
        if now is not None:
            if not out["matched"]:
                deadline = time.monotonic() + 10
                while any(not x.get_matched_subscriptions() for x in w.values()) and time.monotonic() < deadline:
                    time.sleep(0.01)
                out["matched"] = all(x.get_matched_subscriptions() for x in w.values())
            if out["sent_setpoint_at"] is None:
                w["js"].write(JointState(name=[joint], position=[TARGET]))
                out["sent_setpoint_at"] = now
            elif out["moved_at"] is None:
                if abs(out["joint"][-1][1] - TARGET) < 0.05:
                    out["moved_at"] = now
            elif out["gravity_off_at"] is None:
                if now >= out["moved_at"] + SETTLE:
                    w["gravity"].write(Bool(data=False))
                    out["gravity_off_at"] = now
            elif out["malformed_at"] is None and now >= out["gravity_off_at"] + WINDOW + 0.1:
                for _kind, topic, msg in malformed(joint):
                    w[topic].write(msg)
                out["malformed_at"] = now
            elif phase is None and out["malformed_at"] is not None and now >= out["malformed_at"] + 0.3:
                w["pause"].write(Bool(data=True))
                phase, clock_changed = "pausing", time.monotonic()
        if got:
            last_data = time.monotonic()
        elif last_data is not None and phase not in ("pausing", "stepping") and time.monotonic() - last_data > 1.5:
            break                                   # the run is over
        time.sleep(0.005)
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), sys.argv[2], float(sys.argv[3]))
