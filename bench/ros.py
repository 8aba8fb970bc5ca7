"""ROS 2 interface cost: publish-to-receive latency on loopback, and scenes' real-time factors with the
interface on and off.

latency   this process publishes sensor_msgs/JointState messages shaped like the robot's (its joint
          names, position and velocity) through the publisher's own path (a CDR template patched in
          place, Cyclone's C writer, /joint_states QoS, loopback-only participant) at ``--rate`` Hz;
          header.stamp carries the wall clock (CLOCK_REALTIME, shared by the processes of one machine)
          at the write. A subscriber in a separate process (cyclonedds alone, a waitset on the reader)
          takes each message as it arrives and records receive − stamp. Median, p90, p99, max.
rtf       each scene of ``--scenes`` (default: the default scene; walls-body-brace-climb, whose
          force-torque sensors add one /fts topic per cut; eels-lateral-undulation, rk4 at 1 ms, where
          the interface ticks every tenth step) run in this process with and without ``--ros2``
          (publisher, command sources, simulation control at the default rates: clock, joint_states,
          imu, wrench 100 Hz, tf 50 Hz, each at most one message a base step), in turns, best of
          ``--repeats`` each after a warm-up run. Both at the scene's own step: ``--ros2`` no longer
          changes it (a topic faster than the step is published every step; the achieved rates are
          printed). DDS endpoints open before the timed loop (Component.before_run), so neither run
          includes the ~0.3 s of opening them. Wall time and this process's CPU time (what other work
          takes of a shared core is not in it; Cyclone's own threads are), each the best of its runs.
per tick  one more run of each scene with ``--ros2``, every method the interface's components run per
          tick (update, output, hold, edit_state) timed with perf_counter: median µs per call and µs
          per interface tick (its calls per tick × median). Not the timed runs: the timers cost ~0.2 µs
          a call. "est." is that per-tick cost times the run's interface ticks against the wall time
          off: on a machine shared with other work the difference of two best walls swings by more
          than the interface costs, the calls' own timings much less.

Target: the interface costs ≤ 10 % of each scene's wall time at the default rates.

    python bench/ros.py [--duration 10] [--repeats 7] [--scenes NAME[:S],...] [--messages 2000] [--rate 100]
                        [--json FILE]
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


#: scenes timed by default, with their simulated seconds per run (the first takes --duration)
SCENES = (("surface-screw-traverse", None), ("walls-body-brace-climb", 4.0), ("eels-lateral-undulation", 2.0))


def _session(scene: str, on: bool, duration: float, modules: int | None, domain: int, dt: float | None = None):
    from snakesim.components.ros2.attach import attach_ros2
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry
    from snakesim.framework.session import Session

    reg = default_registry()
    r = resolve(scene, search_path=reg.assembly_paths(), overrides=[f"robot.modules={modules}"] if modules else [],
                sim_overrides={"duration": duration, **({"dt": dt} if dt else {})})
    name = attach_ros2(r, reg, params={"domain_id": domain}) if on else None
    return Session(r, reg), name


def rtf(scene: str, duration: float, repeats: int, modules: int | None, domain: int) -> dict:
    """Best wall time of the scene with and without the interface, in turns. Were ``--ros2`` to change the
    step (it did until the achieved-rate rule), the scene is also timed at that step ("same"), against
    which the interface's cost is counted; "own" is always the scene as it comes."""
    on = _session(scene, True, duration, modules, domain)
    own = _session(scene, False, duration, modules, domain)
    sessions = {"own": own, "on": on}
    if on[0].resolved.sim.dt != own[0].resolved.sim.dt:
        sessions["same"] = _session(scene, False, duration, modules, domain, on[0].resolved.sim.dt)
    for s, _ in sessions.values():
        s.run()                                               # warm-up: compilation, DDS opened
    walls = {k: [] for k in sessions}
    cpus = {k: [] for k in sessions}
    summary = None
    for _ in range(repeats):
        for key, (s, _) in sessions.items():                 # in turns: a slow spell of the machine hits all
            summary = s.run().summary
            walls[key].append(summary["wall_time_s"])
            cpus[key].append(summary["cpu_time_s"])          # this process's CPU: time others take is not in it
    s_on, name = sessions["on"]
    run = s_on.plan.caches[name]
    pub = s_on.plan.components[name]
    best = {k: min(v) for k, v in walls.items()}
    off = best.get("same", best["own"])
    cpu = {k: min(v) for k, v in cpus.items()}
    cpu_off = cpu.get("same", cpu["own"])
    messages = sum(run.published.values())                   # the run's cache counts over every run
    T = summary["sim_time_s"]
    return {"scene": scene, "sim_time_s": T, "dt_s": s_on.resolved.sim.dt, "own_dt_s": own[0].resolved.sim.dt,
            "wall_off_s": off, "wall_on_s": best["on"], "wall_own_s": best["own"], "walls_s": walls,
            "rtf_off": T / off, "rtf_on": T / best["on"], "rtf_own": T / best["own"],
            "ratio_on_off": best["on"] / off, "cost_pct": 100.0 * (best["on"] - off) / off,
            "cpu_off_s": cpu_off, "cpu_on_s": cpu["on"], "cpus_s": cpus,
            "cpu_cost_pct": 100.0 * (cpu["on"] - cpu_off) / cpu_off,
            "cost_vs_own_pct": 100.0 * (best["on"] - best["own"]) / best["own"], "topic_rates": pub.topic_rates,
            "achieved_rates": getattr(pub, "achieved_rates", pub.topic_rates), "publisher_rate_hz": pub.rate,
            "messages_per_run": messages // (repeats + 1),
            "publish_us_per_message": 1e6 * run.publish_time / max(messages, 1)}


PER_TICK = ("update", "output", "hold", "edit_state")


def per_tick(scene: str, duration: float, modules: int | None, domain: int) -> dict:
    """Median µs per call of each ROS 2 component method the step loop runs, and µs per interface tick."""
    import time

    probe, _ = _session(scene, True, duration, modules, domain)
    classes = {type(c) for c in probe.plan.components.values() if type(c).__module__.startswith("snakesim.components.ros2")}
    del probe
    calls: dict[str, list] = {}
    saved = []
    perf = time.perf_counter
    for cls in classes:
        for meth in PER_TICK:
            f = getattr(cls, meth, None)
            if f is None or getattr(f, "__module__", "").startswith("snakesim.framework"):
                continue                                      # the framework's no-op default: never run

            def timed(self, *a, _f=f, _k=f"{cls.type_name}.{meth}"):
                t0 = perf()
                r = _f(self, *a)
                calls.setdefault(_k, []).append(perf() - t0)
                return r
            saved.append((cls, meth, cls.__dict__.get(meth)))
            setattr(cls, meth, timed)
    try:
        s, name = _session(scene, True, duration, modules, domain)
        s.run()
        calls.clear()
        s.run()
        ticks = s.plan.caches[name].tick
    finally:
        for cls, meth, f in saved:
            if f is None:
                delattr(cls, meth)
            else:
                setattr(cls, meth, f)
    out = {k: {"median_us": 1e6 * float(np.median(v)), "calls_per_tick": len(v) / ticks} for k, v in calls.items()}
    return {"ticks": ticks, "methods": out,
            "us_per_tick": sum(m["median_us"] * m["calls_per_tick"] for m in out.values())}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=10.0, help="simulated s per run of the first scene")
    ap.add_argument("--repeats", type=int, default=7, help="timed runs per configuration (best counts)")
    ap.add_argument("--scenes", default=",".join(n if d is None else f"{n}:{d:g}" for n, d in SCENES),
                    help="scenes to time, NAME[:SIMULATED_S] comma-separated (default: %(default)s)")
    ap.add_argument("--modules", type=int, default=None, help="robot modules (default: the scene's)")
    ap.add_argument("--messages", type=int, default=2000, help="latency samples (0: skip the latency)")
    ap.add_argument("--rate", type=float, default=100.0, help="latency publish rate, Hz")
    ap.add_argument("--domain", type=int, default=150 + os.getpid() % 50, help="DDS domain id")
    ap.add_argument("--json", dest="json_path", help="write the figures here")
    a = ap.parse_args(argv)
    scenes = []
    for item in a.scenes.split(","):
        name, _, sec = item.strip().partition(":")
        scenes.append((name, float(sec) if sec else a.duration))
    lat = latency(a.messages, a.rate, a.modules or 10, a.domain) if a.messages else None
    results = []
    for k, (scene, duration) in enumerate(scenes):
        r = rtf(scene, duration, a.repeats, a.modules, a.domain + 1 + k)
        r["per_tick"] = per_tick(scene, duration, a.modules, a.domain + 1 + k)
        # the same cost from the per-tick breakdown: less noisy than the difference of two walls on a shared
        # machine, blind to what the framework does around the calls (sink checks, the gates' timing)
        r["cost_from_ticks_pct"] = (100.0 * r["per_tick"]["us_per_tick"] * 1e-6 * r["per_tick"]["ticks"]
                                    / r["wall_off_s"])
        results.append(r)
    if lat:
        print(f"publish-to-receive latency, loopback, JointState of {lat['joints']} joints ({lat['bytes']} B) "
              f"at {lat['rate_hz']:g} Hz, {lat['messages']} messages, subscriber in another process")
        print(f"  {'median':>10} {'p90':>10} {'p99':>10} {'max':>10}")
        print(f"  {lat['median_us']:8.1f}µs {lat['p90_us']:8.1f}µs {lat['p99_us']:8.1f}µs {lat['max_us']:8.1f}µs\n")
    print(f"interface on and off in turns, best of {a.repeats} (target ≤ 10 %; cost: wall on against off at the "
          f"interface's step, the scene's own; CPU: the same in this process's CPU time; est.: µs/tick × ticks "
          f"against off)")
    print(f"  {'scene':<26} {'sim s':>6} {'dt s':>6} {'off s':>7} {'on s':>7} {'RTF off':>8} {'RTF on':>8} "
          f"{'cost':>7} {'CPU':>7} {'µs/msg':>7} {'µs/tick':>8} {'ticks':>6} {'est.':>6}")
    for r in results:
        print(f"  {r['scene']:<26} {r['sim_time_s']:6g} {r['dt_s']:6g} {r['wall_off_s']:7.3f} {r['wall_on_s']:7.3f} "
              f"{r['rtf_off']:8.1f} {r['rtf_on']:8.1f} {r['cost_pct']:+6.1f}% {r['cpu_cost_pct']:+6.1f}% "
              f"{r['publish_us_per_message']:7.1f} "
              f"{r['per_tick']['us_per_tick']:8.1f} {r['per_tick']['ticks']:6d} {r['cost_from_ticks_pct']:5.1f}%")
        if r["dt_s"] != r["own_dt_s"]:
            print(f"  {'':<26} own step {r['own_dt_s']:g} s: RTF {r['rtf_own']:.1f}, --ros2 costs "
                  f"{r['cost_vs_own_pct']:+.1f} % against it")
    for r in results:
        rates = ", ".join(f"{k} {v:g}" + (f" (asked {r['topic_rates'][k]:g})" if v < r['topic_rates'][k] - 1e-9 else "")
                          for k, v in r["achieved_rates"].items())
        print(f"\n{r['scene']}: topics, Hz: {rates}; {r['messages_per_run']} messages a run")
        print(f"  per interface tick ({r['per_tick']['ticks']} ticks), median µs a call × calls a tick:")
        for k, m in sorted(r["per_tick"]["methods"].items()):
            print(f"    {k:<34} {m['median_us']:6.2f} µs × {m['calls_per_tick']:.2f}")
    if a.json_path:
        with open(a.json_path, "w") as f:
            json.dump({"machine": platform.platform(), "python": sys.version.split()[0], "repeats": a.repeats,
                       "latency": lat, "rtf": results}, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
