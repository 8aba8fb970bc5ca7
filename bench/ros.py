"""ROS 2 interface cost: publish-to-receive latency on loopback, and the default scene's real-time factor
with the interface on and off.

latency   this process publishes sensor_msgs/JointState messages shaped like the robot's (its joint
          names, position and velocity) through the publisher's own path (a CDR template patched in
          place, Cyclone's C writer, /joint_states QoS, loopback-only participant) at ``--rate`` Hz;
          header.stamp carries the wall clock (CLOCK_REALTIME, shared by the processes of one machine)
          at the write. A subscriber in a separate process (cyclonedds alone, a waitset on the reader)
          takes each message as it arrives and records receive − stamp. Median, p90, p99, max.
rtf       the default scene (its own integrator and rates; ``--modules`` overrides the robot's) run in
          this process with and without ``--ros2`` (publisher, command source, simulation control at the
          default rates: clock, joint_states, imu, wrench 100 Hz, tf 50 Hz), in turns, best of
          ``--repeats`` each after a warm-up run. ``--ros2`` runs the scene at the topics' period (10 ms
          where the scene's base step is 20 ms: attach._control_period), so the interface's cost is
          measured against the scene at that same step ("off, same dt"); the scene at its own step
          ("off, own dt") shows what the shorter step costs on top. DDS endpoints open before the
          timed loop (Component.before_run), so neither includes the ~0.3 s of opening them.

Target: the interface costs ≤ 10 % of the default scene's wall time at the default rates.

    python bench/ros.py [--duration 2] [--repeats 3] [--messages 2000] [--rate 100] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time

import numpy as np

SUBSCRIBER = r'''
import json, sys, time
from cyclonedds.core import ReadCondition, SampleState, ViewState, InstanceState, WaitSet
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration
from snakesim.components.ros2.messages import JointState
from snakesim.components.ros2.transport import cyclone_xml
domain, n = int(sys.argv[1]), int(sys.argv[2])
dom = Domain(domain, cyclone_xml("127.0.0.1", domain))
dp = DomainParticipant(domain)
reader = DataReader(dp, Topic(dp, "rt/joint_states", JointState),
                    Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10),
                        Policy.DataRepresentation(use_cdrv0_representation=True)))
ws = WaitSet(dp)
ws.attach(ReadCondition(reader, SampleState.NotRead | ViewState.Any | InstanceState.Any))
print(json.dumps({"ready": True}), flush=True)
lat = []
end = time.monotonic() + 120
while len(lat) < n and time.monotonic() < end:
    ws.wait(duration(milliseconds=200))
    for m in reader.take(N=100):
        if isinstance(m, JointState):
            now = time.time_ns()
            lat.append((now - (m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec)) * 1e-3)
print(json.dumps({"latency_us": lat}), flush=True)
'''


def latency(messages: int, rate: float, modules: int, domain: int) -> dict:
    from snakesim.components.multibody.robot_model import RobotModel
    from snakesim.components.ros2 import messages as M
    from snakesim.components.ros2.template import CdrTemplate, RawWriter
    from snakesim.components.ros2.transport import Ros2Participant

    robot = RobotModel.load(design="eels-1.0", modules=modules)
    nj = robot.nj
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("CYCLONEDDS_URI", None)
    sub = subprocess.Popen([sys.executable, "-c", SUBSCRIBER, str(domain), str(messages)],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert json.loads(sub.stdout.readline()) == {"ready": True}, sub.stderr.read()
        dds = Ros2Participant(domain)
        tpl = CdrTemplate.of(M.JointState(name=list(robot.joints)),
                             {"position": (lambda m, v: setattr(m, "position", list(v)), nj),
                              "velocity": (lambda m, v: setattr(m, "velocity", list(v)), nj)},
                             [lambda m, tm: setattr(m.header, "stamp", tm)])
        writer = RawWriter(dds.writer("/joint_states", M.JointState))
        time.sleep(1.5)                                      # discovery
        q = np.zeros(nj)
        period = 1.0 / rate
        nxt = time.perf_counter()
        for k in range(messages + 50):                       # a few spare: the first may precede matching
            q[:] = 1e-3 * k
            tpl.set_floats("position", q)
            tpl.set_floats("velocity", q)
            sec, nsec = divmod(time.time_ns(), 1_000_000_000)
            tpl.set_stamp(sec, nsec)
            writer.write(tpl.buf)
            nxt += period
            while time.perf_counter() < nxt:
                pass                                          # spin: a sleep's jitter is not the transport's
        out, err = sub.communicate(timeout=60)
        dds.close()
    finally:
        if sub.poll() is None:
            sub.kill()
            sub.wait()
    lat = np.array(json.loads(out.strip().splitlines()[-1])["latency_us"])
    return {"messages": int(len(lat)), "rate_hz": rate, "joints": nj, "bytes": len(tpl.buf),
            "median_us": float(np.median(lat)), "p90_us": float(np.percentile(lat, 90)),
            "p99_us": float(np.percentile(lat, 99)), "max_us": float(lat.max())}


def rtf(duration: float, repeats: int, modules: int | None, domain: int) -> dict:
    from snakesim.components.ros2.attach import attach_ros2
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry
    from snakesim.framework.session import Session

    reg = default_registry()
    scene = reg.default_assembly()

    def session(on, dt=None):
        sim = {"duration": duration, **({"dt": dt} if dt else {})}
        r = resolve(scene, search_path=reg.assembly_paths(),
                    overrides=[f"robot.modules={modules}"] if modules else [], sim_overrides=sim)
        name = attach_ros2(r, reg, params={"domain_id": domain}) if on else None
        return Session(r, reg), name

    on = session(True)
    ros_dt = on[0].resolved.sim.dt
    sessions = {"off": session(False, ros_dt), "on": on, "own": session(False)}
    for s, _ in sessions.values():
        s.run()                                               # warm-up: compilation, DDS opened
    walls = {"off": [], "on": [], "own": []}
    summary = None
    for _ in range(repeats):
        for key, (s, _) in sessions.items():
            summary = s.run().summary
            walls[key].append(summary["wall_time_s"])
    s_on, name = sessions["on"]
    run = s_on.plan.caches[name]
    pub = s_on.plan.components[name]
    off, on, own = min(walls["off"]), min(walls["on"]), min(walls["own"])
    ticks = sum(run.published.values())
    T = summary["sim_time_s"]
    return {"scene": scene, "sim_time_s": T, "ros_dt_s": ros_dt, "own_dt_s": sessions["own"][0].resolved.sim.dt,
            "wall_off_s": off, "wall_on_s": on, "wall_own_s": own, "rtf_off": T / off, "rtf_on": T / on,
            "rtf_own": T / own, "ratio_on_off": on / off, "cost_pct": 100.0 * (on - off) / off,
            "topic_rates": pub.topic_rates, "publish_us_per_message": 1e6 * run.publish_time / max(ticks, 1)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=2.0, help="simulated s per run of the default scene")
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per configuration (best counts)")
    ap.add_argument("--modules", type=int, default=None, help="robot modules (default: the scene's)")
    ap.add_argument("--messages", type=int, default=2000, help="latency samples")
    ap.add_argument("--rate", type=float, default=100.0, help="latency publish rate, Hz")
    ap.add_argument("--domain", type=int, default=150 + os.getpid() % 50, help="DDS domain id")
    ap.add_argument("--json", dest="json_path", help="write the figures here")
    a = ap.parse_args(argv)
    lat = latency(a.messages, a.rate, a.modules or 10, a.domain)
    r = rtf(a.duration, a.repeats, a.modules, a.domain + 1)
    print(f"publish-to-receive latency, loopback, JointState of {lat['joints']} joints ({lat['bytes']} B) "
          f"at {lat['rate_hz']:g} Hz, {lat['messages']} messages, subscriber in another process")
    print(f"  {'median':>10} {'p90':>10} {'p99':>10} {'max':>10}")
    print(f"  {lat['median_us']:8.1f}µs {lat['p90_us']:8.1f}µs {lat['p99_us']:8.1f}µs {lat['max_us']:8.1f}µs")
    print(f"\n{r['scene']}: {r['sim_time_s']:g} s simulated, best of {a.repeats}; topics {r['topic_rates']}")
    print(f"  {'interface':>22} {'wall s':>8} {'RTF':>7}")
    print(f"  {'off, own dt ' + format(r['own_dt_s'], 'g'):>22} {r['wall_own_s']:8.3f} {r['rtf_own']:7.3f}")
    print(f"  {'off, same dt ' + format(r['ros_dt_s'], 'g'):>22} {r['wall_off_s']:8.3f} {r['rtf_off']:7.3f}")
    print(f"  {'on (--ros2)':>22} {r['wall_on_s']:8.3f} {r['rtf_on']:7.3f}")
    print(f"  ratio on/off {r['ratio_on_off']:.3f}: interface cost {r['cost_pct']:+.1f} % "
          f"(target ≤ 10 %); {r['publish_us_per_message']:.1f} µs per message published")
    if a.json_path:
        with open(a.json_path, "w") as f:
            json.dump({"machine": platform.platform(), "python": sys.version.split()[0], "latency": lat,
                       "rtf": r}, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
