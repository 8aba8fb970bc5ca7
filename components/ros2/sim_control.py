"""ROS 2 simulation control: pause, resume, step N base steps, lockstep, reset and robot placement.

A gate (:meth:`Component.hold <snakesim.framework.component.Component.hold>`) and a
state editor (:meth:`Component.edit_state <snakesim.framework.component.Component.edit_state>`,
:mod:`snakesim.framework.state_edit`): the step loop calls :meth:`Ros2SimControl.hold`
once per base step, after the discrete updates of tick t (so the publisher has already
sent the state at t) and before the integrator advances past t, then
:meth:`Ros2SimControl.edit_state`. While the run is held it polls its topics every
``poll_s`` of wall time; nothing else runs. ``snakesim run --ros2`` adds it
(``--ros2-lockstep`` turns lockstep on); in YAML::

    sim: {type: ros2_sim_control, rate: 100, params: {lockstep: true, hold_timeout: 30}}

Topics (ROS 2 default QoS; types from rosbags' standard definitions, :mod:`.messages`):

    /sim/pause   std_msgs/Bool     true: pause (hold at the next control tick, i.e. within one period);
                                   false: resume (drops any steps not yet taken)
    /sim/step    std_msgs/UInt32   pause if running, then advance exactly N base steps (sim.dt each) and
                                   hold again; requests add up
    /sim/reset   std_msgs/Empty    the world back to its initial state (below)
    /sim/set_pose              geometry_msgs/PoseStamped  the robot's root link at a pose in the world frame,
                                   at rest (:mod:`.placement_requests`; with a multibody robot)
    /sim/set_joint_positions   sensor_msgs/JointState     joint angles by URDF name, those joints at rest
    /clock       rosgraph_msgs/Clock  published as soon as the run starts holding, with the time it holds
                                   at (so a stepping client reads the exact time; the publisher's /clock
                                   only ticks at its rate), then again every 1/clock_rate wall s while
                                   it holds, with that same stamp: a paused sim's /clock goes on at its
                                   rate with a frozen time, as Gazebo's does, so a node on use_sim_time
                                   sees the sim alive (and a late joiner gets the time at once)

Services (rmw_cyclonedds' conventions, :mod:`.services`; ``ros2 service call`` works):

    /sim/reset   std_srvs/srv/Empty     as the topic; answered once the reset is handed to the step loop
                                        (every message published after the reply shows the reset world)
    /sim/pause   std_srvs/srv/SetBool   data true pauses, false resumes, as the topic; success true and a
                                        message saying what it did

Reset, like Gazebo's reset_world: every component's continuous and discrete state returns to its value
at t0 (bit for bit) while simulated time keeps running forward, so /clock stays monotonic and a stack on
use_sim_time never sees time jump back. The state at t + dt (t the tick the request is handled at) is
the initial state; the integrator restarts with no history. Command sources keep the last command
(set-points are the stack's, not the world's); per-run caches are kept. Requests are handled at the
control ticks (within one control period) and while held: a reset or placement while paused lets exactly
one base step through (the step that takes the edited state), and the run holds again at t + dt.

Placement (/sim/set_pose, /sim/set_joint_positions) writes the robot provider's state (``robot_state``,
set by ``--ros2`` to the multibody) through the same mechanism: the written values are exact, the rest of
the world moves on over that step as usual.

Lockstep (``lockstep: true``): at each of its ticks (its ``rate``: the control period) the run holds
until a command arrives on the command topics (/joint_commands, /joint_command, /enable_gravity,
/tethers/attached; any message, valid or rejected, counts) or a step or resume request; a command
received since the previous control tick releases the next period at once. So the world never runs
more than one control period ahead of the last command. The command source (``ros2_commands``) reads
commands at its own tick, which comes before the hold in the step: a command that releases the hold at
t is applied from the next control tick (one control period of latency, deterministic). Resume in
lockstep releases one period (the next control tick holds again).

Nothing ever waits unboundedly unnoticed: ``hold_timeout`` (wall s, 0: wait for ever) ends the run
with a stop reason when nothing arrives while held; Ctrl-C interrupts a hold. Malformed placement
requests are rejected with a logged reason naming the field (:mod:`.rejections`, at most once per
second per reason) and counted; the run goes on.

uses robot: RobotModel (optional): joint names and the state layout for placement requests
Ports: none (kept by its hold). Run state (pause flag, step budget, pending edits) lives in ``u.cache``.
"""

from __future__ import annotations

import dataclasses
import math
import time
import weakref

from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Component, Uses

from .commands import GRAVITY_TOPIC, JOINT_TOPIC, TRAJECTORY_TOPIC
from .placement_requests import JOINTS_TOPIC, POSE_TOPIC, joint_positions_write, pose_write
from .rejections import Rejected, RejectionLog
from .tether_commands import TETHER_TOPIC
from .transport import ClosedAfterRun, DdsEndpoint, arrivals_waitset

PAUSE_TOPIC = "/sim/pause"
STEP_TOPIC = "/sim/step"
RESET_TOPIC = "/sim/reset"
RESET_SERVICE = ("/sim/reset", "std_srvs/srv/Empty")
PAUSE_SERVICE = ("/sim/pause", "std_srvs/srv/SetBool")


class Ros2SimControlParams(DdsEndpoint):
    lockstep: bool = Field(False, description="hold at each tick (control period) until a command or step")
    start_paused: bool = Field(False, description="hold at t0 until resumed or stepped")
    hold_timeout: float = Field(0.0, ge=0, description="wall s without any request while held before the run "
                                                       "is stopped; 0: wait for ever")
    poll_s: float = Field(0.001, gt=0, le=0.1, description="wall s between two polls while held")
    services: bool = Field(True, description="offer /sim/reset (std_srvs/Empty) and /sim/pause (std_srvs/SetBool) "
                                             "as ROS 2 services")
    robot_state: str | None = Field(None, description="the component whose continuous state is the robot's "
                                                      "[q, v] (a multibody): /sim/set_pose and "
                                                      "/sim/set_joint_positions write it; None: not offered")
    world_frame: str = Field("world", description="the only frame_id /sim/set_pose accepts")
    max_age: float = Field(0.5, gt=0, description="s; a stamped request older than sim time by more is stale")
    max_abs_position: float = Field(2 * math.pi, gt=0, description="rad; a larger |joint angle| is out of range")
    clock_rate: float = Field(100.0, ge=0, description="Hz of wall time: /clock repeated with the held time "
                                                       "while the run holds (paused, stepping, lockstep), as "
                                                       "the publisher's /clock rate; 0: once per hold only")


class Ros2SimControl(ClosedAfterRun, Component[Ros2SimControlParams]):
    type_name = "ros2_sim_control"
    is_sink = True           # update() at its rate: the control ticks
    robot = Uses(RobotModel, required=False, doc="joint names and state layout for placement requests")

    def setup(self):
        if self.rate is None:
            raise ValueError(f"{self.name}: ros2_sim_control needs a rate (Hz): its ticks are the control "
                             "periods (polling, lockstep)")
        if self.p.robot_state is not None and self.robot is None:
            raise ValueError(f"{self.name}: robot_state '{self.p.robot_state}' needs the robot (uses robot: "
                             "the component that provides it)")

    @property
    def placement(self) -> bool:
        """Whether /sim/set_pose and /sim/set_joint_positions are offered."""
        return self.p.robot_state is not None

    def make_cache(self, x, u, y) -> "SimControlRun":
        return SimControlRun(paused=self.p.start_paused)

    # -- DDS ------------------------------------------------------------------------------------
    def before_run(self, t0, u):
        """The DDS readers and service servers, opened before the clock starts."""
        if u.cache.dds is None:
            self._open(u.cache)

    def _open(self, run: "SimControlRun") -> None:
        from . import messages as M
        from .transport import Ros2Participant

        dds = Ros2Participant(self.p.domain_id, self.p.interface)
        topics = [(PAUSE_TOPIC, M.Bool), (STEP_TOPIC, M.UInt32), (RESET_TOPIC, M.Empty)]
        if self.placement:
            topics += [(POSE_TOPIC, M.PoseStamped), (JOINTS_TOPIC, M.JointState)]
        run.readers = tuple((topic, typ, dds.reader(topic, typ, on_malformed=run.malformed))
                            for topic, typ in topics)
        if self.p.lockstep:
            run.commands = tuple((dds.reader(tp, typ), typ) for tp, typ in ((TRAJECTORY_TOPIC, M.JointTrajectory),
                                                                      (JOINT_TOPIC, M.JointState),
                                                                      (GRAVITY_TOPIC, M.Bool),
                                                                      (TETHER_TOPIC, M.UInt8MultiArray)))
        if self.p.services:
            from .services import ServiceServer

            run.services = {name: ServiceServer(dds, name, srv) for name, srv in (RESET_SERVICE, PAUSE_SERVICE)}
        run.clock = dds.writer("/clock", M.Clock)
        run.arrivals = arrivals_waitset(dds, [r for _, _, r in run.readers] + [s.reader for s in run.services.values()]
                                 + [r for r, _ in run.commands])
        run.dds = dds
        self.p.announce(dds, "snakesim_sim_control")              # ros2 node list (:mod:`.node_graph`)
        run.finalizer = weakref.finalize(run, dds.close)

    def poll(self, run: "SimControlRun", t: float = 0.0) -> bool:
        """Take every request that arrived (topics and service calls), in order of their source timestamps;
        True when one did. ``t``: sim time, for stale stamps and the log."""
        if run.dds is None:
            self._open(run)
        if not run.arrivals():                  # nothing arrived on any reader: one C call, not one take each
            return False
        got = []
        for topic, typ, reader in run.readers:
            for m in reader.take(N=256):
                if isinstance(m, typ):                    # not an InvalidSample (a writer went away)
                    info = getattr(m, "sample_info", None)
                    got.append((getattr(info, "source_timestamp", 0), len(got), topic, m, None))
        for name, server in run.services.items():
            for call in server.take():
                info = getattr(call.request, "sample_info", None)
                got.append((getattr(info, "source_timestamp", 0), len(got), name, call.request, call))
        got.sort(key=lambda g: g[:2])
        for _, _, topic, m, call in got:
            self.request(run, topic, m, t, call)
        n = 0
        for reader, typ in run.commands:
            n += sum(1 for m in reader.take(N=256) if isinstance(m, typ))      # not an InvalidSample
        run.tokens += n
        return bool(got or n)

    def request(self, run: "SimControlRun", topic: str, msg, t: float = 0.0, call=None) -> None:
        """Handle one request: /sim/pause (Bool, or the SetBool service), /sim/step (UInt32), /sim/reset
        (Empty, or the Empty service), /sim/set_pose, /sim/set_joint_positions (validated; rejected ones
        are logged and counted)."""
        run.requests += 1
        if topic == STEP_TOPIC:
            run.paused = True
            run.budget += int(msg.data)
        elif topic == PAUSE_TOPIC:
            run.paused = bool(msg.data)
            if not run.paused:
                run.budget = 0
            if call is not None:
                run.services[topic].reply(call, success=True,
                                          message=f"paused at t = {t:.9g} s" if run.paused else "running")
        elif topic == RESET_TOPIC:
            run.pending.append(("reset", None, None, call))
        else:
            try:
                if topic == POSE_TOPIC:
                    idx, values = pose_write(msg, self.robot, t, self.p.world_frame, self.p.max_age)
                else:
                    idx, values = joint_positions_write(msg, self.robot, t, self.p.max_age, self.p.max_abs_position)
            except Rejected as e:
                self._reject(run, t, e)
                return
            run.pending.append(("write", idx, values, None))

    def _reject(self, run: "SimControlRun", t: float, err: Exception) -> None:
        run.rejected += 1
        run.last_reason = str(err)
        if run.log is None:
            run.log = RejectionLog(self.name)
        run.log(t, err)

    # -- state edits -----------------------------------------------------------------------------
    def edit_state(self, t, u, edit):
        """Hand the pending reset and placement requests to the step loop; answer reset service calls."""
        run = u.cache
        if not run.pending:
            return
        for kind, idx, values, call in run.pending:
            if kind == "reset":
                edit.reset()
                run.resets += 1
            else:
                try:
                    edit.write(self.p.robot_state, idx, values)
                except ValueError as e:
                    self._reject(run, t, Rejected(f"{POSE_TOPIC}: {e}"))
                    continue
                run.placements += 1
            if call is not None:
                run.services[RESET_SERVICE[0]].reply(call)
        run.pending.clear()

    # -- the loop ---------------------------------------------------------------------------------
    def update(self, t, xd, u):
        """A control tick: take requests; in lockstep, hold from here unless a command came."""
        run = u.cache
        self.poll(run, t)
        if self.p.lockstep and run.budget == 0:
            run.paused = True

    def hold(self, t, u):
        run = u.cache
        if not run.paused:
            return
        if run.budget == 0 and not (self.p.lockstep and run.tokens) and not run.pending:
            self.poll(run, t)
        while True:
            if run.pending:                     # a reset or placement: this one step applies it, then hold again
                run.holding = False
                return
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
                run.clock_due = now + 1.0 / self.p.clock_rate if self.p.clock_rate > 0 else math.inf
            elif now >= run.clock_due:              # paused: /clock goes on at its rate, time frozen
                self._announce(run, t)
                run.clock_due = max(run.clock_due + 1.0 / self.p.clock_rate, now)
            elif self.p.hold_timeout and now - run.since > self.p.hold_timeout:
                self.stop(f"held {now - run.since:.3g} s with no request (hold_timeout {self.p.hold_timeout:g} s)")
                run.holding = False
                return
            time.sleep(self.p.poll_s)
            if self.poll(run, t):
                run.since = time.monotonic()

    def _announce(self, run: "SimControlRun", t: float) -> None:
        from . import messages as M

        run.clock.write(M.Clock(clock=M.time_msg(t)))
        run.held_at = t


@dataclasses.dataclass(eq=False)
class SimControlRun:
    """One run's control state (``u.cache``): paused, the step budget, lockstep tokens, pending state edits,
    DDS endpoints."""

    paused: bool = False
    budget: int = 0                  # base steps granted while paused
    tokens: int = 0                  # commands received since the last release (lockstep)
    holding: bool = False
    since: float = 0.0
    held_at: float | None = None     # sim time of the last hold
    clock_due: float = math.inf      # wall (monotonic) s of the next held /clock
    holds: int = 0
    requests: int = 0
    pending: list = dataclasses.field(default_factory=list)   # (kind, index, values, service call) to edit
    resets: int = 0                  # resets handed to the step loop
    placements: int = 0              # placement writes handed to the step loop
    rejected: int = 0
    last_reason: str = ""
    log: RejectionLog | None = None
    dds: object = None
    readers: tuple = ()
    services: dict = dataclasses.field(default_factory=dict)
    commands: tuple = ()
    arrivals: object = None          # transport.Arrivals on every reader: whether anything arrived (poll)
    clock: object = None
    finalizer: object = None

    def malformed(self, topic: str, reason: str) -> None:
        """A sample the transport dropped as malformed (it logged it): counted with the rejections."""
        self.rejected += 1
        self.last_reason = f"{topic}: dropped a malformed sample: {reason}"

    def close(self) -> None:
        if self.finalizer is not None:
            self.finalizer()
        self.finalizer, self.dds, self.commands, self.readers, self.services = None, None, (), (), {}

