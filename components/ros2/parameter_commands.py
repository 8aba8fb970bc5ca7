"""Named numeric parameters from an autonomy stack: one rcl_interfaces/ParameterEvent topic read by a
discrete source, validated whole, each parameter held (zero-order hold) until changed or deleted.

The shared machinery of the command sources that set a controller's parameters at run time
(``ros2_gait_commands`` on /gait/parameters, ``ros2_brace_commands`` on /brace/parameters). A
subclass names its ``TOPIC``, ``NODE`` and ``PARAMETERS`` (name -> :class:`Admissible`) and declares
one output of shape (1,) per parameter, of the same name::

    changed_parameters (and new_parameters)   value.type 3 (double) or 2 (integer): set the named parameter
    deleted_parameters                        give the named parameter back to the scene (output NaN)

Why ParameterEvent: it is the standard message of *named, typed* parameters (rcl_interfaces ships with
every ROS 2 install, ``ros2 param`` speaks it), so a command says which parameter it sets and the order
of fields is never guessed; a Float64MultiArray would need a documented position per parameter.

Before the first command (and after a parameter is deleted) an output is NaN: the controller uses its
own parameter. A message naming some parameters leaves the others as they were.

Rejected (logged on ``snakesim.ros2`` naming the field and value, at most once per second per reason,
counted, never applied; the run goes on): no parameter at all; an unknown or repeated name; a value
type other than double or integer; a non-finite or out-of-range value.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from snakesim.framework import Component, Output

from .command_reader import CommandReaderRun
from .rejections import Rejected, RejectionLog
from .transport import ClosedAfterRun, DdsEndpoint

DOUBLE, INTEGER = 3, 2          # rcl_interfaces/ParameterType
EVENT = "rcl_interfaces/msg/ParameterEvent"


@dataclasses.dataclass(frozen=True)
class Admissible:
    """What values a commanded parameter takes: above ``low`` (``strict``: not equal to it), or one of
    ``values`` when given; ``unit`` for the messages."""

    unit: str = ""
    low: float = -math.inf
    strict: bool = False
    values: tuple[float, ...] | None = None

    def check(self, topic: str, where: str, name: str, v: float) -> None:
        """Raise :class:`Rejected` naming the field when ``v`` is not admissible."""
        if not math.isfinite(v):
            raise Rejected(f"{topic}: {where}.value ({name}) = {v} is not finite")
        if self.values is not None:
            if v not in self.values:
                raise Rejected(f"{topic}: {where}.value ({name}) = {v:g} is not "
                               f"{' or '.join(f'{a:+g}' for a in self.values)}")
        elif v < self.low or (self.strict and v == self.low):
            raise Rejected(f"{topic}: {where}.value ({name}) = {v:g} {self.unit} is out of range "
                           f"({'>' if self.strict else '>='} {self.low:g})")


def parameter_port(unit: str) -> Output:
    """One commanded parameter's output: shape (1,), NaN while not commanded."""
    return Output(shape=(1,), unit=unit, feedthrough=(), may_be_nan=True)


class ParameterCommandsParams(DdsEndpoint):
    pass


class ParameterCommands(ClosedAfterRun, Component[ParameterCommandsParams]):
    """Base of the ParameterEvent command sources (module docstring); not registered itself."""

    TOPIC: str = ""
    NODE: str = ""
    PARAMETERS: dict[str, Admissible] = {}

    rejected = Output(shape=(1,), unit="1", feedthrough=())
    applied = Output(shape=(1,), unit="1", feedthrough=())

    def setup(self):
        if self.rate is None:
            raise ValueError(f"{self.name}: {self.type_name} needs a rate (Hz): it polls its topic at each tick")

    def make_cache(self, x, u, y) -> CommandReaderRun:
        return CommandReaderRun()

    @classmethod
    def validate(cls, msg) -> dict[str, float]:
        """{name: value (NaN: back to the scene's)} of a valid message; :class:`Rejected` naming the field."""
        topic, known = cls.TOPIC, cls.PARAMETERS
        valid = ", ".join(known)
        out: dict[str, float] = {}
        entries = [(f"changed_parameters[{i}]", p) for i, p in enumerate(msg.changed_parameters)]
        entries += [(f"new_parameters[{i}]", p) for i, p in enumerate(msg.new_parameters)]
        for where, p in entries:
            name = p.name
            if name not in known:
                raise Rejected(f"{topic}: {where}.name = {name!r} is not a parameter here (valid: {valid})")
            if name in out:
                raise Rejected(f"{topic}: {where}.name = {name!r} is given twice")
            typ = p.value.type
            if typ == DOUBLE:
                v = float(p.value.double_value)
            elif typ == INTEGER:
                v = float(p.value.integer_value)
            else:
                raise Rejected(f"{topic}: {where}.value.type = {typ} for {name!r} is not a number "
                               f"({DOUBLE}: double or {INTEGER}: integer)")
            known[name].check(topic, where, name, v)
            out[name] = v
        for i, name in enumerate(msg.deleted_parameters):
            pname = getattr(name, "name", name)
            if pname not in known:
                raise Rejected(f"{topic}: deleted_parameters[{i}].name = {pname!r} is not a parameter here "
                               f"(valid: {valid})")
            if pname in out:
                raise Rejected(f"{topic}: deleted_parameters[{i}].name = {pname!r} is also set")
            out[pname] = math.nan
        if not out:
            raise Rejected(f"{topic}: changed_parameters, new_parameters and deleted_parameters are all empty")
        return out

    def output(self, t, x, u, y):
        run = u.cache
        if not run.started:
            for name in self.PARAMETERS:
                getattr(y, name)[0] = np.nan
            y.rejected[0] = y.applied[0] = 0.0
            run.started = True
        if run.dds is None:
            from . import messages as M

            self._type = M.ros_type(EVENT)
            run.open(self.p, self.TOPIC, self._type, self.NODE)
        for m in run.reader.take(N=256):
            if not isinstance(m, self._type):            # an InvalidSample: a writer went away
                continue
            try:
                values = self.validate(m)
            except Rejected as e:
                run.rejected += 1
                y.rejected[0] = run.rejected
                if run.log is None:
                    run.log = RejectionLog(self.name)
                run.log(t, e)
                continue
            for name, v in values.items():
                getattr(y, name)[0] = v
            run.applied += 1
            y.applied[0] = run.applied
