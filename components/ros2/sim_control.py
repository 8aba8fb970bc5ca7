"""ROS 2 simulation control: pause, resume, step N base steps, and lockstep with an autonomy stack.

A gate (:meth:`Component.hold <snakesim.framework.component.Component.hold>`):
the step loop calls :meth:`Ros2SimControl.hold` once per base step, after the
discrete updates of tick t (so the publisher has already sent the state at t)
and before the integrator advances past t. While the run is held it polls its
topics every ``poll_s`` of wall time; nothing else runs. ``snakesim run --ros2``
adds it (``--ros2-lockstep`` turns lockstep on); in YAML::

    sim: {type: ros2_sim_control, rate: 100, params: {lockstep: true, hold_timeout: 30}}

Topics (ROS 2 default QoS; types from rosbags' standard definitions, :mod:`.messages`). Topics, not
services, this round:

    /sim/pause   std_msgs/Bool     true: pause (hold at the next control tick, i.e. within one period);
                                   false: resume (drops any steps not yet taken)
    /sim/step    std_msgs/UInt32   pause if running, then advance exactly N base steps (sim.dt each) and
                                   hold again; requests add up
    /clock       rosgraph_msgs/Clock  published once each time the run starts holding, with the time it
                                   holds at (so a stepping client reads the exact time; the publisher's
                                   /clock only ticks at its rate)

Lockstep (``lockstep: true``): at each of its ticks (its ``rate``: the control period) the run holds
until a command arrives on the command topics (/joint_commands, /joint_command, /enable_gravity; any
message, valid or rejected, counts) or a step or resume request; a command received since the
previous control tick releases the next period at once. So the world never runs more than one control
period ahead of the last command. The command source (``ros2_commands``) reads commands at its own
tick, which comes before the hold in the step: a command that releases the hold at t is applied from
the next control tick (one control period of latency, deterministic). Resume in lockstep releases one
period (the next control tick holds again).

Nothing ever waits unboundedly unnoticed: ``hold_timeout`` (wall s, 0: wait for ever) ends the run
with a stop reason when nothing arrives while held; Ctrl-C interrupts a hold. Reset is not offered yet.

Ports: none (kept by its hold). Run state (pause flag, step budget) lives in ``u.cache``.
"""

from __future__ import annotations

import dataclasses
import logging
import time
import weakref

from pydantic import Field

from snakesim.framework import Component

from .commands import GRAVITY_TOPIC, JOINT_TOPIC, TRAJECTORY_TOPIC
from .transport import DdsEndpoint

log = logging.getLogger("snakesim.ros2")

PAUSE_TOPIC = "/sim/pause"
STEP_TOPIC = "/sim/step"


class Ros2SimControlParams(DdsEndpoint):
    lockstep: bool = Field(False, description="hold at each tick (control period) until a command or step")
    start_paused: bool = Field(False, description="hold at t0 until resumed or stepped")
    hold_timeout: float = Field(0.0, ge=0, description="wall s without any request while held before the run "
                                                       "is stopped; 0: wait for ever")
    poll_s: float = Field(0.001, gt=0, le=0.1, description="wall s between two polls while held")


class Ros2SimControl(Component[Ros2SimControlParams]):
    type_name = "ros2_sim_control"
    Params = Ros2SimControlParams
    is_sink = True           # update() at its rate: the control ticks

    def setup(self):
        if self.rate is None:
            raise ValueError(f"{self.name}: ros2_sim_control needs a rate (Hz): its ticks are the control "
                             "periods (polling, lockstep)")

    def make_cache(self, x, u, y) -> "SimControlRun":
        return SimControlRun(paused=self.p.start_paused)

    # -- DDS ------------------------------------------------------------------------------------
    def _open(self, run: "SimControlRun") -> None:
        from . import messages as M
        from .transport import Ros2Participant

        dds = Ros2Participant(self.p.domain_id, self.p.interface)
        run.pause = dds.reader(PAUSE_TOPIC, M.Bool)
        run.step = dds.reader(STEP_TOPIC, M.UInt32)
        if self.p.lockstep:
            run.commands = tuple((dds.reader(tp, typ), typ) for tp, typ in ((TRAJECTORY_TOPIC, M.JointTrajectory),
                                                                      (JOINT_TOPIC, M.JointState),
                                                                      (GRAVITY_TOPIC, M.Bool)))
        run.clock = dds.writer("/clock", M.Clock)
        run.dds = dds
        run.finalizer = weakref.finalize(run, dds.close)

    def poll(self, run: "SimControlRun") -> bool:
        """Take every request that arrived; True when one did."""
        from . import messages as M

        if run.dds is None:
            self._open(run)
        got = []
        for reader, typ in ((run.pause, M.Bool), (run.step, M.UInt32)):
            for m in reader.take(N=256):
                if isinstance(m, typ):
                    info = getattr(m, "sample_info", None)
                    got.append((getattr(info, "source_timestamp", 0), len(got), m))
        got.sort(key=lambda g: g[:2])
        for _, _, m in got:
            self.request(run, m)
        n = 0
        for reader, typ in run.commands:
            n += sum(1 for m in reader.take(N=256) if isinstance(m, typ))      # not an InvalidSample
        run.tokens += n
        return bool(got or n)

    def request(self, run: "SimControlRun", msg) -> None:
        """Apply one /sim/pause (Bool) or /sim/step (UInt32) request."""
        from . import messages as M

        if isinstance(msg, M.Bool):
            run.paused = bool(msg.data)
            if not run.paused:
                run.budget = 0
        else:
            run.paused = True
            run.budget += int(msg.data)
        run.requests += 1

    # -- the loop ---------------------------------------------------------------------------------
    def update(self, t, xd, u):
        """A control tick: take requests; in lockstep, hold from here unless a command came."""
        run = u.cache
        self.poll(run)
        if self.p.lockstep and run.budget == 0:
            run.paused = True

    def hold(self, t, u):
        run = u.cache
        if not run.paused:
            return
        if run.budget == 0 and not (self.p.lockstep and run.tokens):
            self.poll(run)
        while True:
            if run.budget > 0:
                run.budget -= 1
                run.holding = False
                return
            if self.p.lockstep and run.tokens:            # a command: release this control period
                run.tokens = 0
                run.paused = False
            if not run.paused:
                run.holding = False
                return
            now = time.monotonic()
            if not run.holding:
                self._announce(run, t)
                run.holding, run.since = True, now
                run.holds += 1
            elif self.p.hold_timeout and now - run.since > self.p.hold_timeout:
                self.stop(f"held {now - run.since:.3g} s with no request (hold_timeout {self.p.hold_timeout:g} s)")
                run.holding = False
                return
            time.sleep(self.p.poll_s)
            if self.poll(run):
                run.since = time.monotonic()

    def _announce(self, run: "SimControlRun", t: float) -> None:
        from . import messages as M

        run.clock.write(M.Clock(clock=M.time_msg(t)))
        run.held_at = t


@dataclasses.dataclass(eq=False)
class SimControlRun:
    """One run's control state (``u.cache``): paused, the step budget, lockstep tokens, DDS endpoints."""

    paused: bool = False
    budget: int = 0                  # base steps granted while paused
    tokens: int = 0                  # commands received since the last release (lockstep)
    holding: bool = False
    since: float = 0.0
    held_at: float | None = None     # sim time of the last hold
    holds: int = 0
    requests: int = 0
    dds: object = None
    pause: object = None
    step: object = None
    commands: tuple = ()
    clock: object = None
    finalizer: object = None

    def close(self) -> None:
        if self.finalizer is not None:
            self.finalizer()
        self.finalizer, self.dds, self.commands = None, None, ()
