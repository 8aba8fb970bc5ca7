"""ROS 2 command source: joint set-points and gravity from an autonomy stack, validated before the physics.

A discrete source (give it a ``rate``; ``snakesim run --ros2`` adds it at 100 Hz).
At each tick it takes, without blocking, every sample that arrived since the
last tick (DDS readers with ROS 2's default QoS: reliable, keep last 10,
volatile, on ``rt/<topic>``), validates each message, applies the valid ones
in their order of arrival (source timestamps) and holds the result until the
next valid command (zero-order hold, per joint: a command naming some joints
leaves the others as they were).

Topics (types: :mod:`.messages`, from rosbags' standard definitions):

    /joint_commands   trajectory_msgs/JointTrajectory   joint_names and points (positions and/or
                                                        velocities), followed in time (below)
    /joint_command    sensor_msgs/JointState            name with position and/or velocity (effort is
                                                        ignored)
    /enable_gravity   std_msgs/Bool                     gravity output 1 (on) or 0 (off), for the
                                                        multibody's gravity input in "scale" mode

Trajectories: point i is due at T_i = start + points[i].time_from_start, where
start is header.stamp (simulated time) or, for an unstamped (zero) header,
the sim time of the tick that took the message. Before T_0 the joints keep
their previous set-points; between T_i and T_(i+1) every value a point gives
(positions, velocities) is interpolated linearly in time at each tick of the
source; from the last point's time on its values are held. A single point
with time_from_start 0 is applied at once. time_from_start must be >= 0 and
strictly increasing. A later command (a trajectory or a JointState) takes
over the joints it names from any trajectory still running; the others go
on.

Set-points follow the PID's convention (:mod:`snakesim.components.control.pid`):
``setpoint`` is the position (rad) of position-controlled joints and the
velocity (rad/s) of velocity-controlled ones (the PID's modes: ``kind_modes``
and ``modes`` as its ``kind_gains``/``gains``, which ``--ros2`` copies from
the scene's PID; default screws velocity: screw speeds are joint velocities
by name);
``rate`` is the velocity given for a position joint (the PID's ``rate_ref``),
0 when the command gives none. A position joint needs a position, a velocity
joint a velocity; a velocity joint's position is ignored.

Validation: a message is applied whole or not at all. Rejected, with a
warning on logger ``snakesim.ros2`` naming the topic, field and value, counted
in ``rejected`` and never applied (the run goes on):

    unknown or repeated joint names; an empty name list or trajectory
    NaN or infinite positions or velocities
    positions/velocities whose length is neither 0 nor that of the names
    a position joint without a position, a velocity joint without a velocity
    |position| > max_abs_position, |velocity| > max_abs_velocity (out of range)
    a stamped header (stamp ≠ 0) older than sim time by more than max_age (stale);
    an unstamped (zero) header is not checked
    a trajectory's time_from_start negative or not increasing from one point to the next

The warning for one reason is written at most once per wall second, with a
count of those not written (:mod:`.rejections`).

Before the first valid command the set-points hold the measured joint
positions at the first tick (``q`` wired; else ``initial``, else 0), the
velocity joints at ``initial`` (default 0), and ``gravity`` is NaN (the multibody then uses its own
``gravity`` parameter).

The DDS participant opens on the first tick (so ``snakesim check`` opens none)
and closes with the run's cache.

uses robot: RobotModel: joint names (URDF) and kinds
in   q[nj]          rad, measured joint positions (role joint_positions; optional)
out  setpoint[nj]   rad (position joints) or rad/s (velocity joints), for pid.setpoint
     rate[nj]       rad/s, for pid.rate_ref
     gravity[1]     1 on, 0 off, NaN before any /enable_gravity, for multibody.gravity (scale mode)
     rejected[1]    messages rejected so far
     applied[1]     messages applied so far
"""

from __future__ import annotations

import dataclasses
import math
import weakref

import numpy as np
from pydantic import Field

from snakesim.components.control.joint_selection import per_joint
from snakesim.components.control.pid import DEFAULT_GAINS, Mode
from snakesim.components.control.setpoint_ports import setpoint_outputs
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import joint_shape
from snakesim.components.port_roles import JOINT_POSITIONS
from snakesim.framework import Component, Input, Output, Uses

from .rejection_counts import count_rejection
from .rejections import Rejected, RejectionLog, check_stamp
from .transport import DdsEndpoint

__all__ = ["Rejected", "Ros2Commands", "Trajectory"]

TRAJECTORY_TOPIC = "/joint_commands"
JOINT_TOPIC = "/joint_command"
GRAVITY_TOPIC = "/enable_gravity"


class Ros2CommandsParams(DdsEndpoint):
    joints: bool = Field(True, description=f"accept joint set-points ({TRAJECTORY_TOPIC}, {JOINT_TOPIC})")
    gravity: bool = Field(True, description=f"accept {GRAVITY_TOPIC}")
    kind_modes: dict[str, Mode] = Field(default_factory=dict,
                                        description="control mode per joint kind, as the PID's kind_gains.*.mode "
                                                    "(default: screws velocity, others position)")
    modes: dict[str, Mode] = Field(default_factory=dict,
                                   description="control mode by joint name/pattern, as the PID's gains.*.mode")
    initial: dict[str, float] = Field(default_factory=dict,
                                      description="set-points before the first command when q is not wired, "
                                                  "by name/pattern (default 0)")
    max_age: float = Field(0.5, gt=0, description="s; a stamped command older than sim time by more is stale")
    max_abs_position: float = Field(2 * math.pi, gt=0, description="rad; larger |position| is out of range")
    max_abs_velocity: float = Field(50.0, gt=0, description="rad/s; larger |velocity| is out of range")


class Ros2Commands(Component[Ros2CommandsParams]):
    type_name = "ros2_commands"
    robot = Uses(RobotModel)

    q = Input(shape=joint_shape, unit="rad", default=np.nan, role=JOINT_POSITIONS)
    setpoint, rate = setpoint_outputs(("q",))
    gravity = Output(shape=(1,), unit=None, feedthrough=(), may_be_nan=True)
    rejected = Output(shape=(1,), unit="1", feedthrough=())
    applied = Output(shape=(1,), unit="1", feedthrough=())

    def setup(self):
        p, robot = self.p, self.robot
        self.velocity_limit = robot.velocity_limits()
        if self.rate is None:
            raise ValueError(f"{self.name}: ros2_commands needs a rate (Hz): it polls its topics at each tick")
        names = list(robot.joints)
        self.index = {n: i for i, n in enumerate(names)}
        bad = set(p.kind_modes) - set(DEFAULT_GAINS)
        if bad:
            raise ValueError(f"{self.name}: kind_modes: unknown joint kind(s) {sorted(bad)}; "
                             f"kinds: {', '.join(DEFAULT_GAINS)}")
        explicit = per_joint(names, p.modes, f"{self.name}: modes")
        modes = [m if m is not None else p.kind_modes.get(k, DEFAULT_GAINS[k]["mode"])
                 for k, m in zip(robot.joint_kinds, explicit)]
        self.velocity_mask = np.array([m == "velocity" for m in modes], dtype=bool)
        init = np.array(per_joint(names, p.initial, f"{self.name}: initial", 0.0), dtype=float)
        if not np.all(np.isfinite(init)):
            raise ValueError(f"{self.name}: initial values must be finite")
        self.initial_setpoint = init

    def make_cache(self, x, u, y) -> "CommandsRun":
        return CommandsRun()

    # -- validation: pure functions of the message and sim time -----------------------------
    def _stamp(self, topic: str, header, t: float) -> None:
        check_stamp(topic, header, t, self.p.max_age)

    def _values(self, topic: str, names, positions, velocities, where: str):
        """Validate one command; its (joint indices, setpoint, rate) to apply."""
        p = self.p
        names = list(names)
        if not names:
            raise Rejected(f"{topic}: {where[0]} is empty")
        idx = []
        seen = set()
        for k, n in enumerate(names):
            i = self.index.get(n)
            if i is None:
                raise Rejected(f"{topic}: {where[0]}[{k}] = '{n}' is not a joint of the robot "
                               f"(joints: {', '.join(self.robot.joints)})")
            if n in seen:
                raise Rejected(f"{topic}: {where[0]}[{k}] = '{n}' appears twice")
            seen.add(n)
            idx.append(i)
        arrays = {}
        for field, values, limit in ((where[1], positions, p.max_abs_position), (where[2], velocities, p.max_abs_velocity)):
            values = list(values)
            if len(values) not in (0, len(names)):
                raise Rejected(f"{topic}: {field} has {len(values)} values for {len(names)} {where[0]} "
                               f"(expected 0 or {len(names)})")
            for k, v in enumerate(values):
                if not math.isfinite(v):
                    raise Rejected(f"{topic}: {field}[{k}] ({names[k]}) = {v} is not finite")
                if abs(v) > limit:
                    raise Rejected(f"{topic}: {field}[{k}] ({names[k]}) = {v:g} is out of range (|value| <= {limit:g})")
                if field == where[2] and abs(v) > self.velocity_limit[idx[k]]:
                    raise Rejected(f"{topic}: {field}[{k}] ({names[k]}) = {v:g} rad/s exceeds the joint's URDF velocity "
                                   f"limit {self.velocity_limit[idx[k]]:g} rad/s (the motor cannot follow it)")
            arrays[field] = np.array(values, dtype=float) if values else None
        pos, vel = arrays[where[1]], arrays[where[2]]
        idx = np.array(idx, dtype=np.intp)
        vmask = self.velocity_mask[idx]
        if vel is None and vmask.any():
            k = int(np.flatnonzero(vmask)[0])
            raise Rejected(f"{topic}: {where[2]} is empty but {where[0]}[{k}] = '{names[k]}' is velocity-controlled")
        if pos is None and (~vmask).any():
            k = int(np.flatnonzero(~vmask)[0])
            raise Rejected(f"{topic}: {where[1]} is empty but {where[0]}[{k}] = '{names[k]}' is position-controlled")
        zero = np.zeros(len(idx))
        sp = np.where(vmask, vel if vel is not None else zero, pos if pos is not None else zero)
        rate = np.where(vmask, 0.0, vel if vel is not None else zero)
        return idx, sp, rate

    def validate(self, topic: str, msg, t: float):
        """What a valid message applies: ('joints', idx, setpoint, rate), ('trajectory', Trajectory) or
        ('gravity', 1.0 | 0.0). Raises :class:`Rejected` (its text names the field and value) otherwise."""
        if topic == GRAVITY_TOPIC:
            return ("gravity", 1.0 if msg.data else 0.0)
        self._stamp(topic, msg.header, t)
        if topic == TRAJECTORY_TOPIC:
            return ("trajectory", self._trajectory(topic, msg, t))
        return ("joints",) + self._values(topic, msg.name, msg.position, msg.velocity,
                                          ("name", "position", "velocity"))

    def _trajectory(self, topic: str, msg, t: float) -> "Trajectory":
        if not msg.points:
            raise Rejected(f"{topic}: points is empty")
        s = msg.header.stamp
        start = s.sec + 1e-9 * s.nanosec if (s.sec or s.nanosec) else t
        times, sps, rates = [], [], []
        idx = None
        for i, pt in enumerate(msg.points):
            d = pt.time_from_start
            tfs = d.sec + 1e-9 * d.nanosec
            if tfs < 0:
                raise Rejected(f"{topic}: points[{i}].time_from_start = {tfs:.9g} s is negative")
            if times and not tfs > times[-1] - start:
                raise Rejected(f"{topic}: points[{i}].time_from_start = {tfs:.9g} s is not after "
                               f"points[{i - 1}].time_from_start = {times[-1] - start:.9g} s")
            idx, sp, rate = self._values(topic, msg.joint_names, pt.positions, pt.velocities,
                                         ("joint_names", f"points[{i}].positions", f"points[{i}].velocities"))
            times.append(start + tfs)
            sps.append(sp)
            rates.append(rate)
        return Trajectory(idx, np.array(times), np.array(sps), np.array(rates))

    # -- DDS --------------------------------------------------------------------------------
    def topics(self) -> list[tuple[str, type]]:
        from . import messages as M

        out = []
        if self.p.joints:
            out += [(TRAJECTORY_TOPIC, M.JointTrajectory), (JOINT_TOPIC, M.JointState)]
        if self.p.gravity:
            out.append((GRAVITY_TOPIC, M.Bool))
        return out

    def _open(self, run: "CommandsRun") -> None:
        from .transport import Ros2Participant

        dds = Ros2Participant(self.p.domain_id, self.p.interface)
        run.readers = tuple((topic, typ, dds.reader(topic, typ)) for topic, typ in self.topics())
        run.dds = dds
        self.p.announce(dds, "snakesim_commands")              # ros2 node list (:mod:`.node_graph`)
        run.finalizer = weakref.finalize(run, dds.close)

    def _take(self, run: "CommandsRun") -> list:
        got = []
        for topic, typ, reader in run.readers:
            for m in reader.take(N=256):
                if isinstance(m, typ):            # an InvalidSample: a writer went away
                    info = getattr(m, "sample_info", None)
                    got.append((getattr(info, "source_timestamp", 0), len(got), topic, m))
        got.sort(key=lambda g: g[:2])
        return [(topic, m) for _, _, topic, m in got]

    # -- the per-tick path --------------------------------------------------------------------
    def output(self, t, x, u, y):
        run = u.cache
        if not run.started:
            q = np.asarray(u.q, dtype=float)
            init = self.initial_setpoint
            y.setpoint[:] = np.where(self.velocity_mask | ~np.isfinite(q), init, q)
            y.rate[:] = 0.0
            y.gravity[0] = np.nan
            y.rejected[0] = y.applied[0] = 0.0
            run.started = True
        if run.dds is None:
            self._open(run)
        for topic, msg in self._take(run):
            self.apply(run, topic, msg, t, y)
        if run.trajectories:
            run.trajectories = [tr for tr in run.trajectories if tr.follow(t, y.setpoint, y.rate)]

    def apply(self, run: "CommandsRun", topic: str, msg, t: float, y) -> bool:
        """Validate ``msg`` and apply it to the held outputs ``y`` (a trajectory: to the running ones,
        followed at each tick); False (logged, counted) if rejected."""
        try:
            what = self.validate(topic, msg, t)
        except Rejected as e:
            count_rejection(run, self.name, t, e, y.rejected)
            return False
        if what[0] == "gravity":
            y.gravity[0] = what[1]
        else:
            new = what[1] if what[0] == "trajectory" else None
            idx = new.idx if new is not None else what[1]
            run.trajectories = [tr for tr in run.trajectories if tr.release(idx)]      # taken over
            if new is not None:
                run.trajectories.append(new)
            else:
                _, idx, sp, rate = what
                y.setpoint[idx] = sp
                y.rate[idx] = rate
        run.applied += 1
        y.applied[0] = run.applied
        return True


@dataclasses.dataclass(eq=False)
class Trajectory:
    """A running JointTrajectory: joints ``idx``, point times ``times`` (s, simulated, increasing) and
    per point the set-points and rates of those joints; ``live`` marks the joints no later command
    took over."""

    idx: np.ndarray
    times: np.ndarray
    setpoints: np.ndarray          # (points, joints)
    rates: np.ndarray
    live: np.ndarray | None = None

    def __post_init__(self):
        if self.live is None:
            self.live = np.ones(self.idx.size, dtype=bool)

    def values(self, t: float):
        """(set-points, rates) at sim time t, or None before the first point's time."""
        T = self.times
        i = int(np.searchsorted(T, t, side="right")) - 1
        if i < 0:
            return None
        if i >= T.size - 1:
            return self.setpoints[-1], self.rates[-1]
        a = (t - T[i]) / (T[i + 1] - T[i])
        sp, rt = self.setpoints, self.rates
        return sp[i] + a * (sp[i + 1] - sp[i]), rt[i] + a * (rt[i + 1] - rt[i])

    def follow(self, t: float, setpoint: np.ndarray, rate: np.ndarray) -> bool:
        """Write the values at t into the outputs (live joints only); False once it is over."""
        v = self.values(t)
        if v is not None:
            live = self.live
            setpoint[self.idx[live]] = v[0][live]
            rate[self.idx[live]] = v[1][live]
        return not t >= self.times[-1]

    def release(self, idx: np.ndarray) -> bool:
        """Hand the joints ``idx`` to a later command; False when no joint is left."""
        self.live &= ~np.isin(self.idx, idx)
        return bool(self.live.any())


@dataclasses.dataclass(eq=False)
class CommandsRun:
    """One run's command state (``u.cache``): the DDS readers (opened on the first tick) and counts."""

    started: bool = False
    dds: object = None
    readers: tuple = ()
    rejected: int = 0
    applied: int = 0
    last_reason: str = ""
    trajectories: list = dataclasses.field(default_factory=list)   # running JointTrajectory commands
    log: RejectionLog | None = None
    finalizer: object = None

    def close(self) -> None:
        """Close the participant now (otherwise when the run's cache is dropped)."""
        if self.finalizer is not None:
            self.finalizer()
        self.finalizer, self.dds, self.readers = None, None, ()
