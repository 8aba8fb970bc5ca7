"""ROS 2 gait commands: the shape gaits' parameters (serpenoid_gait, helical_gait) from an autonomy stack.

A discrete source (give it a ``rate``; ``snakesim run --ros2`` adds it at the command rate, 100 Hz,
for the first serpenoid_gait or helical_gait whose command inputs the scene leaves free, and wires
each output into the gait's input of the same name). At each tick it takes every message that
arrived, validates each whole, and holds the last valid value of each parameter (zero-order hold,
per parameter: a message naming some parameters leaves the others as they were).

    /gait/parameters   rcl_interfaces/ParameterEvent   changed_parameters (and new_parameters): the
                                                       parameters to set, by name; deleted_parameters:
                                                       names given back to the scene's value

Why ParameterEvent: it is the standard message of *named, typed* parameters (rcl_interfaces ships with
every ROS 2 install, ``ros2 param`` speaks it), so a command says which parameter it sets and the
order of fields is never guessed; a Float64MultiArray would need a documented position per
parameter. From a shell::

    ros2 topic pub --once /gait/parameters rcl_interfaces/msg/ParameterEvent \
        "{changed_parameters: [{name: frequency, value: {type: 3, double_value: 0.8}}]}"

Parameters (value.type 3 double or 2 integer): ``amplitude`` rad >= 0, ``frequency`` Hz >= 0,
``wavelength`` joints > 0 (serpenoid), ``phase_step`` rad (helical), ``direction`` +1 or −1.
A gait that lacks an input ignores that parameter.

Before the first command (and after a parameter is deleted) the outputs are NaN: the gait uses its
own parameter.

Rejected (logged on ``snakesim.ros2`` naming the field and value, at most once per second per reason,
counted, never applied; the run goes on): no parameter at all; an unknown or repeated name; a value
type other than double or integer; a non-finite or out-of-range value.

out  amplitude[1] rad, frequency[1] Hz, wavelength[1], phase_step[1] rad, direction[1]  (NaN: not commanded)
     rejected[1]   messages rejected so far
     applied[1]    messages applied so far
"""

from __future__ import annotations

import math

import numpy as np

from snakesim.framework import Component, Output

from .command_reader import CommandReaderRun
from .rejections import Rejected, RejectionLog
from .transport import DdsEndpoint

GAIT_TOPIC = "/gait/parameters"
#: the commanded parameters, in output order, with their admissible range (low, strict) and unit
PARAMETERS = {"amplitude": (0.0, False, "rad"), "frequency": (0.0, False, "Hz"), "wavelength": (0.0, True, "joints"),
              "phase_step": (-math.inf, False, "rad"), "direction": (None, False, "")}
DOUBLE, INTEGER = 3, 2          # rcl_interfaces/ParameterType


class Ros2GaitCommandsParams(DdsEndpoint):
    pass


def _port(unit):
    return Output(shape=(1,), unit=unit, feedthrough=(), may_be_nan=True)


class Ros2GaitCommands(Component[Ros2GaitCommandsParams]):
    type_name = "ros2_gait_commands"
    Params = Ros2GaitCommandsParams

    amplitude = _port("rad")
    frequency = _port("Hz")
    wavelength = _port("1")
    phase_step = _port("rad")
    direction = _port("1")
    rejected = Output(shape=(1,), unit="1", feedthrough=())
    applied = Output(shape=(1,), unit="1", feedthrough=())

    def setup(self):
        if self.rate is None:
            raise ValueError(f"{self.name}: ros2_gait_commands needs a rate (Hz): it polls its topic at each tick")

    def make_cache(self, x, u, y) -> "CommandReaderRun":
        return CommandReaderRun()

    @staticmethod
    def validate(msg) -> dict[str, float]:
        """{name: value (NaN: back to the scene's)} of a valid message; :class:`Rejected` naming the field."""
        out: dict[str, float] = {}
        entries = [(f"changed_parameters[{i}]", p) for i, p in enumerate(msg.changed_parameters)]
        entries += [(f"new_parameters[{i}]", p) for i, p in enumerate(msg.new_parameters)]
        for where, p in entries:
            name = p.name
            if name not in PARAMETERS:
                raise Rejected(f"{GAIT_TOPIC}: {where}.name = {name!r} is not a gait parameter "
                               f"(valid: {', '.join(PARAMETERS)})")
            if name in out:
                raise Rejected(f"{GAIT_TOPIC}: {where}.name = {name!r} is given twice")
            typ = p.value.type
            if typ == DOUBLE:
                v = float(p.value.double_value)
            elif typ == INTEGER:
                v = float(p.value.integer_value)
            else:
                raise Rejected(f"{GAIT_TOPIC}: {where}.value.type = {typ} for {name!r} is not a number "
                               f"({DOUBLE}: double or {INTEGER}: integer)")
            low, strict, unit = PARAMETERS[name]
            if not math.isfinite(v):
                raise Rejected(f"{GAIT_TOPIC}: {where}.value ({name}) = {v} is not finite")
            if name == "direction":
                if v not in (1.0, -1.0):
                    raise Rejected(f"{GAIT_TOPIC}: {where}.value (direction) = {v:g} is not +1 or -1")
            elif v < low or (strict and v == low):
                raise Rejected(f"{GAIT_TOPIC}: {where}.value ({name}) = {v:g} {unit} is out of range "
                               f"({'>' if strict else '>='} {low:g})")
            out[name] = v
        for i, name in enumerate(msg.deleted_parameters):
            pname = getattr(name, "name", name)
            if pname not in PARAMETERS:
                raise Rejected(f"{GAIT_TOPIC}: deleted_parameters[{i}].name = {pname!r} is not a gait parameter "
                               f"(valid: {', '.join(PARAMETERS)})")
            if pname in out:
                raise Rejected(f"{GAIT_TOPIC}: deleted_parameters[{i}].name = {pname!r} is also set")
            out[pname] = math.nan
        if not out:
            raise Rejected(f"{GAIT_TOPIC}: changed_parameters, new_parameters and deleted_parameters are all empty")
        return out

    def output(self, t, x, u, y):
        run = u.cache
        if not run.started:
            for name in PARAMETERS:
                getattr(y, name)[0] = np.nan
            y.rejected[0] = y.applied[0] = 0.0
            run.started = True
        if run.dds is None:
            self._open(run)
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

    def _open(self, run: "CommandReaderRun") -> None:
        from . import messages as M

        self._type = M.ros_type("rcl_interfaces/msg/ParameterEvent")
        run.open(self.p, GAIT_TOPIC, self._type, "snakesim_gait_commands")
