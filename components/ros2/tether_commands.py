"""ROS 2 tether commands: attach and release the scene's tethers from an autonomy stack.

A discrete source (give it a ``rate``; ``snakesim run --ros2`` adds it at the
command rate, 100 Hz, when the scene has a ``tethers`` component whose
``attached`` input it leaves unconnected, and wires ``attached -> tethers.attached``).
At each tick it takes every message that arrived, validates each whole, and
holds the last valid one (zero-order hold).

    /tethers/attached   std_msgs/UInt8MultiArray   data[j] = 1 attaches tether j, 0 releases it, j in the
                                                   order of the tethers component's ``tethers`` list;
                                                   layout may be empty, else dim[0].size = the tether count

Why UInt8MultiArray: ROS 2 has no standard message of named booleans; a
JointState would call ropes joints and carry three unused float arrays. std_msgs
is on every ROS 2 install, ``ros2 topic pub --once /tethers/attached
std_msgs/msg/UInt8MultiArray "{data: [0]}"`` works as it is, and the tether count
is fixed by the scene, so a whole-vector command (every tether given each time)
is unambiguous; the order is the scene file's.

Before the first valid command the output is NaN: the tethers follow their
own ``attach``/``release`` schedule (``tethers`` reads NaN as "schedule").

Rejected (logged on ``snakesim.ros2`` naming the field and value, at most once per second per reason,
counted, never applied; the run goes on): data of another length than the tether count, a value other
than 0 or 1, a layout whose dim[0].size is not the tether count.

out  attached[n]   1 attached, 0 released, NaN before any command (the tethers' schedule)
     rejected[1]   messages rejected so far
     applied[1]    messages applied so far
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pydantic import Field

from snakesim.framework import Component, Output

from .command_reader import CommandReaderRun
from .rejection_counts import count_rejection
from .rejections import Rejected
from .transport import ClosedAfterRun, DdsEndpoint

TETHER_TOPIC = "/tethers/attached"


class Ros2TetherCommandsParams(DdsEndpoint):
    tethers: int = Field(..., ge=1, description="how many tethers the commanded tethers component has")


class Ros2TetherCommands(ClosedAfterRun, Component[Ros2TetherCommandsParams]):
    type_name = "ros2_tether_commands"

    attached = Output(shape=lambda c: (c.p.tethers,), unit="1", feedthrough=(), may_be_nan=True)
    rejected = Output(shape=(1,), unit="1", feedthrough=())
    applied = Output(shape=(1,), unit="1", feedthrough=())

    def setup(self):
        if self.rate is None:
            raise ValueError(f"{self.name}: ros2_tether_commands needs a rate (Hz): it polls its topic at each tick")

    def make_cache(self, x, u, y) -> "TetherCommandsRun":
        return TetherCommandsRun()

    def validate(self, msg) -> np.ndarray:
        """The 0/1 vector a valid message commands; :class:`Rejected` naming the field otherwise."""
        n = self.p.tethers
        data = list(msg.data)
        if len(data) != n:
            raise Rejected(f"{TETHER_TOPIC}: data has {len(data)} values for {n} tethers (expected {n})")
        for k, v in enumerate(data):
            if v not in (0, 1):
                raise Rejected(f"{TETHER_TOPIC}: data[{k}] = {v} is not 0 (release) or 1 (attach)")
        dims = list(msg.layout.dim)
        if dims and dims[0].size != n:
            raise Rejected(f"{TETHER_TOPIC}: layout.dim[0].size = {dims[0].size} is not the tether count {n}")
        return np.array(data, dtype=float)

    def output(self, t, x, u, y):
        run = u.cache
        if not run.started:
            y.attached[:] = np.nan
            y.rejected[0] = y.applied[0] = 0.0
            run.started = True
        if run.dds is None:
            self._open(run)
        for m in run.reader.take(N=256):
            if not isinstance(m, self._type):            # an InvalidSample: a writer went away
                continue
            try:
                y.attached[:] = self.validate(m)
            except Rejected as e:
                count_rejection(run, self.name, t, e, y.rejected)
                continue
            run.applied += 1
            y.applied[0] = run.applied

    def _open(self, run: "TetherCommandsRun") -> None:
        from . import messages as M

        self._type = M.UInt8MultiArray
        run.open(self.p, TETHER_TOPIC, M.UInt8MultiArray, "snakesim_tether_commands")


@dataclasses.dataclass(eq=False)
class TetherCommandsRun(CommandReaderRun):
    """The command reader's state and the last rejection's reason."""

    last_reason: str = ""
