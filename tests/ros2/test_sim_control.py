"""ros2_sim_control in process: /sim/pause, /sim/step N, lockstep and the hold timeout, over loopback DDS.

The run holds the calling thread, so the requests come from a thread with its own participant on the
same domain (shared_domain: one Cyclone domain per id per process)."""

from __future__ import annotations

import threading
import time

import pytest

from snakesim.framework.registry import default_registry
from snakesim.framework.session import load_session

SCENE = """\
sim: {duration: %(duration)s, dt: 0.001}
components:
  ctl: {type: ros2_sim_control, rate: 100, params: {domain_id: %(domain)d, hold_timeout: %(timeout)s, %(extra)s}}
  src: {type: constant, params: {value: 1.0}}
"""


def _session(tmp_path, domain, duration=0.5, timeout=5.0, extra="lockstep: false"):
    p = tmp_path / "scene.yaml"
    p.write_text(SCENE % {"duration": duration, "domain": domain, "timeout": timeout, "extra": extra})
    return load_session(p, registry=default_registry())


class Client(threading.Thread):
    """A separate participant: waits for its writers to match, then runs ``script(self)``."""

    def __init__(self, domain, script, lockstep=False):
        super().__init__(daemon=True)
        from snakesim.components.ros2 import messages as M
        from snakesim.components.ros2.transport import Ros2Participant

        self.M = M
        self.dds = Ros2Participant(domain)
        self.pause = self.dds.writer("/sim/pause", M.Bool)
        self.step = self.dds.writer("/sim/step", M.UInt32)
        self.gravity = self.dds.writer("/enable_gravity", M.Bool)
        self.clock = self.dds.reader("/clock", M.Clock)
        self.held: list[int] = []                  # /clock announcements (ns) of each hold
        self.script, self.error = script, None

    def wait_matched(self, *writers, timeout=10.0):
        end = time.monotonic() + timeout
        while any(not w.get_matched_subscriptions() for w in writers):
            assert time.monotonic() < end, "writers never matched the run's readers"
            time.sleep(0.005)

    def wait_hold(self, n, timeout=10.0):
        """Until the n-th hold announcement; its time in ns."""
        end = time.monotonic() + timeout
        while len(self.held) < n:
            assert time.monotonic() < end, f"only {len(self.held)} holds seen, waiting for {n}"
            for m in self.clock.take(N=100):
                if isinstance(m, self.M.Clock):
                    ns = m.clock.sec * 1_000_000_000 + m.clock.nanosec
                    if not self.held or ns != self.held[-1]:      # a held /clock repeats its stamp
                        self.held.append(ns)
            time.sleep(0.002)
        return self.held[n - 1]

    def run(self):
        try:
            self.script(self)
        except BaseException as e:           # reported by the test
            self.error = e


def test_start_paused_step_exactly_n_then_resume(tmp_path, dds_domain):
    domain = dds_domain()
    s = _session(tmp_path, domain, extra="start_paused: true")

    def script(c):
        c.wait_matched(c.pause, c.step)
        assert c.wait_hold(1) == 0                  # held at t0
        c.step.write(c.M.UInt32(data=37))
        assert c.wait_hold(2) == 37_000_000         # exactly 37 base steps of 1 ms
        c.step.write(c.M.UInt32(data=5))
        c.step.write(c.M.UInt32(data=8))            # requests add up
        assert c.wait_hold(3) == 50_000_000
        c.pause.write(c.M.Bool(data=False))

    c = Client(domain, script)
    c.start()
    r = s.run()
    c.join(5)
    assert c.error is None, c.error
    run = s.plan.caches["ctl"]
    assert r.summary["completed"] and r.summary["steps"] == 500
    assert run.holds == 3 and run.requests == 4 and not run.paused
    run.close()
    c.dds.close()


def test_pause_while_running_holds_within_one_control_period(tmp_path, dds_domain):
    domain = dds_domain()
    s = _session(tmp_path, domain, duration=30.0, timeout=1.0)       # ended by the hold timeout

    def script(c):
        c.wait_matched(c.pause)
        time.sleep(0.05)
        c.pause.write(c.M.Bool(data=True))
        t = c.wait_hold(1)
        assert t % 10_000_000 == 0                   # at a control tick (100 Hz)
        time.sleep(0.3)
        c.step.write(c.M.UInt32(data=3))
        assert c.wait_hold(2) == t + 3_000_000
        c.pause.write(c.M.Bool(data=False))
        time.sleep(0.1)
        c.pause.write(c.M.Bool(data=True))
        assert c.wait_hold(3) > t

    c = Client(domain, script)
    c.start()
    r = s.run(realtime=True)                         # the last pause is never lifted
    c.join(5)
    assert c.error is None, c.error
    assert "hold_timeout" in r.summary["stop_reason"], r.summary["stop_reason"]
    assert r.summary["held_wall_time_s"] > 0.3
    c.dds.close()


def test_lockstep_advances_one_control_period_per_command(tmp_path, dds_domain):
    domain = dds_domain()
    s = _session(tmp_path, domain, duration=1.0, timeout=0.5, extra="lockstep: true")
    sent = 4

    def script(c):
        c.wait_matched(c.gravity)
        for k in range(sent):
            assert c.wait_hold(k + 1) == 10_000_000 * k       # held at each control tick, in turn
            time.sleep(0.05)                                   # a slow autonomy: the world waits
            c.gravity.write(c.M.Bool(data=True))
        c.wait_hold(sent + 1)

    c = Client(domain, script)
    c.start()
    r = s.run()
    c.join(5)
    assert c.error is None, c.error
    assert c.held == [10_000_000 * k for k in range(sent + 1)]
    assert "hold_timeout" in r.summary["stop_reason"]
    assert r.summary["t_end_s"] == pytest.approx(0.01 * sent + 0.001, abs=1.5e-3)
    c.dds.close()


def test_hold_timeout_ends_a_run_nobody_drives(tmp_path, dds_domain):
    s = _session(tmp_path, dds_domain(), timeout=0.2, extra="start_paused: true")
    t0 = time.monotonic()
    r = s.run()
    assert time.monotonic() - t0 < 5
    assert not r.summary["completed"] and "no request (hold_timeout 0.2 s)" in r.summary["stop_reason"]
    assert r.summary["t_end_s"] <= 0.002


def test_cli_options_add_the_gate(tmp_path):
    from snakesim.components.ros2.attach import attach_ros2, attach_sim_control
    from snakesim.framework.assembly import resolve

    reg = default_registry()
    resolved = resolve("robot-zero-g", search_path=reg.assembly_paths(), overrides=["robot.modules=2"])
    attach_ros2(resolved, reg, params={"domain_id": 9})
    name = attach_sim_control(resolved, {"lockstep": True})
    spec = resolved.components[name]
    assert spec.type == "ros2_sim_control" and spec.params == {"domain_id": 9, "lockstep": True,
                                                               "world_frame": "world", "robot_state": "robot",
                                                                   "clock_rate": 100.0}
    assert spec.uses == {"robot": "robot"}                 # placement: the multibody's state and robot
    assert spec.rate == pytest.approx(100.0)


def test_no_multibody_no_placement_topics(tmp_path):
    """A scene without a multibody robot: the gate offers pause, step and reset, not placement."""
    from snakesim.components.ros2.attach import attach_sim_control
    from snakesim.framework.assembly import resolve

    reg = default_registry()
    p = tmp_path / "scene.yaml"
    p.write_text(SCENE % {"duration": 0.1, "domain": 9, "timeout": 1.0, "extra": "lockstep: false"})
    resolved = resolve(str(p), search_path=reg.assembly_paths())
    del resolved.components["ctl"]
    spec = resolved.components[attach_sim_control(resolved, {"domain_id": 9}, reg)]
    assert "robot_state" not in spec.params and not spec.uses
