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

Trajectories follow ros2_control's joint_trajectory_controller (JTC). A JointTrajectory taken at the
tick t0 replaces whatever trajectory is running, from t0 on. Point i is due at T_i = start +
points[i].time_from_start, where start is header.stamp (simulated time) or, for a zero stamp, t0 ("now";
a future stamp delays every point). From t0 to T_0 the set-point moves from the state at t0 to point 0:
the measured position (``q``; where it is not wired or not finite, the set-point in force) and velocity
(``qd`` where wired and finite, else the rate in force), cubic Hermite when point 0 gives velocities,
linear when it gives positions only. Between two points: quintic when both give positions,
velocities and accelerations, cubic (Hermite) when both give velocities, linear when positions only;
``rate`` is the interpolant's derivative, so position and velocity are continuous at every point that
gives velocities. From the last point on its positions are held (rate 0). A point already due at t0
(T_0 <= t0) is entered where the trajectory is at t0 (no approach segment). For a velocity-controlled
joint (the set-point is a speed) the same rules act one derivative down: the speed in force at t0,
then the points' velocities, cubic when both ends give accelerations, linear otherwise; the last speed
holds. joint_names may be a subset: the joints it does not name hold their set-points (position
joints with rate 0, stopped where they were commanded), a running trajectory on them ends. A
JointState on /joint_command takes over the joints it names from a running trajectory; the others go
on.

Tolerances (JTC's ``constraints``; all off by default, by name/pattern or one value for every
joint): ``path_tolerance`` (rad): while a trajectory runs, a position joint whose measured position is
farther than that from its set-point aborts the trajectory: every joint it drives holds its measured
position (rate 0), as JTC does. ``goal_tolerance`` (rad) with ``goal_time`` (s > 0): a joint not within
its goal tolerance of the last point by T_last + goal_time is a goal violation (the set-points keep
holding the last point). Each violation is a warning on ``snakesim.ros2`` naming the joint, error and
tolerance (rate-limited as rejections), counted on ``aborted`` (path) and ``goal_missed`` (goal); the
run goes on.

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
    a stamped trajectory whose last point is already past (stamp + its time_from_start < sim time)
    accelerations whose length is neither 0 nor that of joint_names, or not finite
    a sample whose CDR does not decode as the topic's type (dropped by the transport, :mod:`.transport`)

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
     qd[nj]         rad/s, measured joint velocities (role joint_velocities; optional): a trajectory's start
out  setpoint[nj]   rad (position joints) or rad/s (velocity joints), for pid.setpoint
     rate[nj]       rad/s, for pid.rate_ref
     gravity[1]     1 on, 0 off, NaN before any /enable_gravity, for multibody.gravity (scale mode)
     rejected[1]    messages rejected so far
     applied[1]     messages applied so far
     aborted[1]     trajectories aborted on a path tolerance so far
     goal_missed[1] trajectories that missed their goal tolerance by goal_time so far
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
from snakesim.components.port_roles import JOINT_POSITIONS, JOINT_VELOCITIES
from snakesim.framework import Component, Input, Output, Uses

from .rejection_counts import count_rejection
from .rejections import Rejected, RejectionLog, check_stamp
from .transport import ClosedAfterRun, DdsEndpoint, arrivals_waitset

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
    path_tolerance: float | dict[str, float] = Field(
        0.0, description="rad, by name/pattern or one for all; a position joint farther from its set-point "
                         "while a trajectory runs aborts it (0: not checked)")
    goal_tolerance: float | dict[str, float] = Field(
        0.0, description="rad, by name/pattern or one for all; checked goal_time after the last point (0: not)")
    goal_time: float = Field(0.0, ge=0, description="s after the last point by which every joint must be within "
                                                    "goal_tolerance (0: the goal is not checked, as JTC)")


class Ros2Commands(ClosedAfterRun, Component[Ros2CommandsParams]):
    type_name = "ros2_commands"
    robot = Uses(RobotModel)

    q = Input(shape=joint_shape, unit="rad", default=np.nan, role=JOINT_POSITIONS)
    setpoint, rate = setpoint_outputs(("q",))
    gravity = Output(shape=(1,), unit=None, feedthrough=(), may_be_nan=True)
    rejected = Output(shape=(1,), unit="1", feedthrough=())
    applied = Output(shape=(1,), unit="1", feedthrough=())
    qd = Input(shape=joint_shape, unit="rad/s", default=np.nan, role=JOINT_VELOCITIES)
    aborted = Output(shape=(1,), unit="1", feedthrough=())
    goal_missed = Output(shape=(1,), unit="1", feedthrough=())

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

        def tolerance(value, what):
            vals = per_joint(names, value, f"{self.name}: {what}", 0.0) if isinstance(value, dict) else [value] * len(names)
            arr = np.array(vals, dtype=float)
            if not np.all(np.isfinite(arr)) or np.any(arr < 0):
                raise ValueError(f"{self.name}: {what} must be finite and >= 0")
            return arr

        self.path_tolerance = tolerance(p.path_tolerance, "path_tolerance")
        self.goal_tolerance = tolerance(p.goal_tolerance, "goal_tolerance")

    def make_cache(self, x, u, y) -> "CommandsRun":
        return CommandsRun()

    # -- validation: pure functions of the message and sim time -----------------------------
    def _stamp(self, topic: str, header, t: float) -> None:
        check_stamp(topic, header, t, self.p.max_age)

    def _values(self, topic: str, names, positions, velocities, where: str, accelerations=None):
        """Validate one command; its (joint indices, setpoint, rate) to apply; with ``accelerations`` (a
        trajectory point) also (positions, velocities, accelerations) as given (None where empty)."""
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
        if accelerations is None:
            return idx, sp, rate
        acc = list(accelerations)
        if len(acc) not in (0, len(names)):
            raise Rejected(f"{topic}: {where[3]} has {len(acc)} values for {len(names)} {where[0]} "
                           f"(expected 0 or {len(names)})")
        for k, v in enumerate(acc):
            if not math.isfinite(v):
                raise Rejected(f"{topic}: {where[3]}[{k}] ({names[k]}) = {v} is not finite")
        return idx, sp, rate, (pos, vel, np.array(acc, dtype=float) if acc else None)

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
        stamped = bool(s.sec or s.nanosec)
        start = s.sec + 1e-9 * s.nanosec if stamped else t
        tfs_prev = None
        times, knots = [], []
        idx = None
        for i, pt in enumerate(msg.points):
            d = pt.time_from_start
            tfs = d.sec + 1e-9 * d.nanosec
            if tfs < 0:
                raise Rejected(f"{topic}: points[{i}].time_from_start = {tfs:.9g} s is negative")
            if tfs_prev is not None and not tfs > tfs_prev:
                raise Rejected(f"{topic}: points[{i}].time_from_start = {tfs:.9g} s is not after "
                               f"points[{i - 1}].time_from_start = {tfs_prev:.9g} s")
            idx, _, _, given = self._values(topic, msg.joint_names, pt.positions, pt.velocities,
                                            ("joint_names", f"points[{i}].positions", f"points[{i}].velocities",
                                             f"points[{i}].accelerations"), pt.accelerations)
            tfs_prev = tfs
            times.append(start + tfs)
            knots.append(given)
        if stamped and times[-1] < t:
            raise Rejected(f"{topic}: header.stamp + points[{len(times) - 1}].time_from_start = {times[-1]:.9g} s "
                           f"is before sim time {t:.9g} s: the whole trajectory is in the past")
        vmask = self.velocity_mask[idx]
        n = idx.size
        nan = np.full(n, np.nan)
        # per knot: value y (position, or speed for velocity joints), slope dy, second derivative ddy (NaN: not given)
        y = np.array([np.where(vmask, v if v is not None else nan, p if p is not None else nan) for p, v, a in knots])
        dy = np.array([np.where(vmask, a if a is not None else nan, v if v is not None else nan) for p, v, a in knots])
        ddy = np.array([np.where(vmask, nan, a if a is not None else nan) for p, v, a in knots])
        return Trajectory(idx, np.array(times), y, dy, ddy, vmask)

    # -- DDS --------------------------------------------------------------------------------
    def topics(self) -> list[tuple[str, type]]:
        from . import messages as M

        out = []
        if self.p.joints:
            out += [(TRAJECTORY_TOPIC, M.JointTrajectory), (JOINT_TOPIC, M.JointState)]
        if self.p.gravity:
            out.append((GRAVITY_TOPIC, M.Bool))
        return out

    def before_run(self, t0, u):
        """The DDS readers, opened before the clock starts."""
        if u.cache.dds is None:
            self._open(u.cache)

    def _open(self, run: "CommandsRun") -> None:
        from .transport import Ros2Participant

        dds = Ros2Participant(self.p.domain_id, self.p.interface)
        run.readers = tuple((topic, typ, dds.reader(topic, typ, on_malformed=run.dropped))
                            for topic, typ in self.topics())
        run.arrivals = arrivals_waitset(dds, [r for _, _, r in run.readers])
        run.dds = dds
        self.p.announce(dds, "snakesim_commands")              # ros2 node list (:mod:`.node_graph`)
        run.finalizer = weakref.finalize(run, dds.close)

    def _take(self, run: "CommandsRun") -> list:
        """Every sample the readers hold (the caller asked ``run.arrivals()`` first), in source-time order."""
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
            run.q, run.qd = u.q, u.qd             # the input views: the same arrays for the whole run
            run.started = True
        if run.dds is None:
            self._open(run)
            y.aborted[0] = y.goal_missed[0] = 0.0
        arrived = run.arrivals()
        if not arrived and not run.trajectories:
            return                                 # the usual tick: nothing arrived, nothing to follow
        msgs = self._take(run) if arrived else []
        if msgs and run.trajectories:              # the set-points in force at t: a new command starts from them
            run.trajectories = [tr for tr in run.trajectories if self._follow(run, tr, t, y)]
        for topic, msg in msgs:
            self.apply(run, topic, msg, t, y)
        while run.malformed:                       # dropped by the transport (it logged them): counted
            run.rejected += 1
            run.last_reason = run.malformed.pop(0)
            y.rejected[0] = run.rejected
        if run.trajectories:
            run.trajectories = [tr for tr in run.trajectories if self._follow(run, tr, t, y)]

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
        elif what[0] == "trajectory":
            new = what[1]
            for tr in run.trajectories:              # replaced from now: what it drove holds (JTC)
                held = tr.idx[tr.live & ~np.isin(tr.idx, new.idx) & ~tr.vmask]
                y.rate[held] = 0.0
            run.trajectories = [new]
            new.begin(t, self._state(run, new.idx, y))
        else:
            _, idx, sp, rate = what
            run.trajectories = [tr for tr in run.trajectories if tr.release(idx)]      # taken over
            y.setpoint[idx] = sp
            y.rate[idx] = rate
        run.applied += 1
        y.applied[0] = run.applied
        return True


    def _state(self, run: "CommandsRun", idx: np.ndarray, y):
        """The state a trajectory starts from: (value, slope) of joints ``idx``: measured position (else the
        set-point) and velocity (else the rate in force) for position joints; the speed in force (slope
        unknown) for velocity joints."""
        vmask = self.velocity_mask[idx]
        sp, rt = y.setpoint[idx], y.rate[idx]
        q = np.asarray(run.q, dtype=float)[idx] if run.q is not None else np.full(idx.size, np.nan)
        qd = np.asarray(run.qd, dtype=float)[idx] if run.qd is not None else np.full(idx.size, np.nan)
        value = np.where(vmask | ~np.isfinite(q), sp, q)
        slope = np.where(vmask, np.nan, np.where(np.isfinite(qd), qd, rt))
        return value, slope

    def _follow(self, run: "CommandsRun", tr: "Trajectory", t: float, y) -> bool:
        """Write ``tr``'s set-points at t, check its tolerances; False once it is over (or aborted)."""
        live = tr.live
        jj = tr.idx[live]
        q = np.asarray(run.q, dtype=float)[jj] if run.q is not None else np.full(jj.size, np.nan)
        pos = ~tr.vmask[live] & np.isfinite(q)
        if t < tr.times[-1] and pos.any():       # path tolerance: against the set-point in force
            tol = self.path_tolerance[jj]
            err = np.abs(q - y.setpoint[jj])
            bad = pos & (tol > 0) & (err > tol)
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                name = self.robot.joints[jj[k]]
                held = jj[pos]
                y.setpoint[held] = q[pos]
                y.rate[jj[~tr.vmask[live]]] = 0.0
                run.aborted += 1
                y.aborted[0] = run.aborted
                self._violation(run, t, f"{TRAJECTORY_TOPIC}: trajectory aborted at t = {t:.6g} s: path tolerance of "
                                        f"{name} violated: |q - setpoint| = {err[k]:.4g} rad > {tol[k]:g} rad; "
                                        f"its joints hold their measured positions")
                return False
        sp, rt = tr.values(t)
        y.setpoint[jj] = sp[live]
        y.rate[jj] = rt[live]
        if t < tr.times[-1]:
            return True
        if self.p.goal_time > 0 and not tr.goal_checked:
            tol = self.goal_tolerance[jj]
            err = np.abs(q - tr.y[-1][live])
            check = pos & (tol > 0)
            if not np.any(check & (err > tol)):
                tr.goal_checked = True                             # reached
            elif t >= tr.times[-1] + self.p.goal_time:
                tr.goal_checked = True
                k = int(np.flatnonzero(check & (err > tol))[0])
                run.goal_missed += 1
                y.goal_missed[0] = run.goal_missed
                self._violation(run, t, f"{TRAJECTORY_TOPIC}: goal tolerance of {self.robot.joints[jj[k]]} violated "
                                        f"at t = {t:.6g} s ({self.p.goal_time:g} s after the last point): "
                                        f"|q - goal| = {err[k]:.4g} rad > {tol[k]:g} rad")
            return not tr.goal_checked
        return False

    def _violation(self, run: "CommandsRun", t: float, text: str) -> None:
        if run.log is None:
            run.log = RejectionLog(self.name)
        run.last_violation = text
        run.log(t, Rejected(text))


def _segment(t0, t1, y0, d0, a0, y1, d1, a1, t):
    """Per joint: value and time derivative at t in [t0, t1] of the segment from (y0, d0, a0) to (y1, d1, a1):
    quintic where both ends give slopes and second derivatives, cubic Hermite where both give slopes,
    linear otherwise (JTC's interpolation)."""
    T = t1 - t0
    if T <= 0:
        return y1.copy(), np.where(np.isfinite(d1), d1, 0.0)
    tau = t - t0
    s = tau / T
    cubic = np.isfinite(d0) & np.isfinite(d1)
    quintic = cubic & np.isfinite(a0) & np.isfinite(a1)
    D0, D1 = np.where(cubic, d0, 0.0), np.where(cubic, d1, 0.0)
    A0, A1 = np.where(quintic, a0, 0.0), np.where(quintic, a1, 0.0)
    # linear
    lin_v = (y1 - y0) / T
    lin_y = y0 + s * (y1 - y0)
    # cubic Hermite
    h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
    g00, g10, g01, g11 = 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s
    cub_y = h00 * y0 + h10 * T * D0 + h01 * y1 + h11 * T * D1
    cub_v = (g00 * y0 + g10 * T * D0 + g01 * y1 + g11 * T * D1) / T
    # quintic: y = c0 + c1 τ + … + c5 τ^5
    dy = y1 - y0
    c3 = (20 * dy - (8 * D1 + 12 * D0) * T - (3 * A0 - A1) * T**2) / (2 * T**3)
    c4 = (-30 * dy + (14 * D1 + 16 * D0) * T + (3 * A0 - 2 * A1) * T**2) / (2 * T**4)
    c5 = (12 * dy - 6 * (D1 + D0) * T - (A0 - A1) * T**2) / (2 * T**5)
    qui_y = y0 + D0 * tau + A0 / 2 * tau**2 + c3 * tau**3 + c4 * tau**4 + c5 * tau**5
    qui_v = D0 + A0 * tau + 3 * c3 * tau**2 + 4 * c4 * tau**3 + 5 * c5 * tau**4
    val = np.where(quintic, qui_y, np.where(cubic, cub_y, lin_y))
    der = np.where(quintic, qui_v, np.where(cubic, cub_v, lin_v))
    return val, der


@dataclasses.dataclass(eq=False)
class Trajectory:
    """A running JointTrajectory (JTC's semantics, see the module docstring): joints ``idx``, point times
    ``times`` (s, simulated, increasing), per point and joint the value ``y`` (position; speed for the
    velocity joints ``vmask``), slope ``dy`` and second derivative ``ddy`` (NaN where the point gives none);
    :meth:`begin` adds the state it starts from; ``live`` marks the joints no later command took over."""

    idx: np.ndarray
    times: np.ndarray
    y: np.ndarray                  # (points, joints)
    dy: np.ndarray
    ddy: np.ndarray
    vmask: np.ndarray
    live: np.ndarray | None = None
    t0: float = -np.inf            # when it was taken
    y0: np.ndarray | None = None   # the state then (value, slope)
    d0: np.ndarray | None = None
    goal_checked: bool = False

    def __post_init__(self):
        if self.live is None:
            self.live = np.ones(self.idx.size, dtype=bool)

    def begin(self, t0: float, state) -> None:
        """Start from ``state`` = (value, slope) of its joints at t0 (the tick that took it)."""
        self.t0 = t0
        self.y0, self.d0 = (np.asarray(a, dtype=float).copy() for a in state)

    def values(self, t: float):
        """(set-points, rates) of its joints at sim time t: the set-point is the interpolant, the rate its
        derivative for position joints (0 for velocity joints); the last point holds (rate 0)."""
        T = self.times
        if t >= T[-1]:
            val, der = self.y[-1].copy(), np.zeros(self.idx.size)
        elif self.y0 is not None and t < T[0]:                    # from the state at t0 to point 0
            nan = np.full(self.idx.size, np.nan)
            val, der = _segment(self.t0, T[0], self.y0, self.d0, nan, self.y[0], self.dy[0], nan, t)
        elif t < T[0]:                                            # not begun (no state): the first point
            val, der = self.y[0].copy(), np.zeros(self.idx.size)
        else:
            i = int(np.searchsorted(T, t, side="right")) - 1
            val, der = _segment(T[i], T[i + 1], self.y[i], self.dy[i], self.ddy[i],
                                self.y[i + 1], self.dy[i + 1], self.ddy[i + 1], t)
        return val, np.where(self.vmask, 0.0, der)

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
    arrivals: object = None          # transport.Arrivals on the readers: whether anything arrived
    rejected: int = 0
    applied: int = 0
    last_reason: str = ""
    trajectories: list = dataclasses.field(default_factory=list)   # the running JointTrajectory (one, or pieces)
    q: object = None                  # the measured state at this tick (inputs), for a trajectory's start
    qd: object = None
    aborted: int = 0                  # trajectories aborted on a path tolerance
    goal_missed: int = 0              # trajectories that missed their goal tolerance
    last_violation: str = ""
    malformed: list = dataclasses.field(default_factory=list)      # reasons of samples the transport dropped
    log: RejectionLog | None = None
    finalizer: object = None

    def dropped(self, topic: str, reason: str) -> None:
        """A sample the transport dropped as malformed (it logged it): counted with the rejections at the tick."""
        self.malformed.append(f"{topic}: dropped a malformed sample: {reason}")

    def close(self) -> None:
        """Close the participant now (otherwise when the run's cache is dropped)."""
        if self.finalizer is not None:
            self.finalizer()
        self.finalizer, self.dds, self.readers = None, None, ()
