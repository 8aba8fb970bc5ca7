"""ROS 2 brace commands: the vertical-mobility controller's targets (``brace_climb``) from an autonomy stack.

Paper 4.3: the brace-and-climb controller is a reference for an autonomy stack to drive or beat, so its
targets come from parameters or from ROS 2. A discrete source (give it a ``rate``; ``snakesim run
--ros2`` adds it at the command rate, 100 Hz, for the first brace_climb whose ``target_force``,
``climb_speed`` or ``descent_speed`` input the scene leaves free, and wires each output into the input of
the same name).
Validation and hold: :mod:`.parameter_commands`.

    /brace/parameters   rcl_interfaces/ParameterEvent   changed_parameters (and new_parameters): the
                                                        targets to set, by name; deleted_parameters:
                                                        names given back to the scene's value

From a shell (climb down at 3 rad/s of screw speed, brace at 80 N per screw)::

    ros2 topic pub --once /brace/parameters rcl_interfaces/msg/ParameterEvent \
        "{changed_parameters: [{name: climb_speed, value: {type: 3, double_value: -3.0}},
                               {name: target_force, value: {type: 3, double_value: 80.0}}]}"

Parameters (value.type 3 double or 2 integer): ``target_force`` N > 0 (the least or mean wall load the
brace regulates to, brace_climb's F*), ``climb_speed`` rad/s (the screws' speed ω* while driving, signed:
negative descends; the controller's phases and ramps still apply: before ``climb_start`` and after
``climb_stop`` the screws are braked whatever the command), ``descent_speed`` m/s >= 0 (the friction
descent's commanded sliding speed, screws braked: > 0 slides down at that speed, 0 stops the slide and
grips; deleted: back to the scene's descent window).

out  target_force[1] N, climb_speed[1] rad/s, descent_speed[1] m/s  (NaN: not commanded)
     rejected[1]   messages rejected so far
     applied[1]    messages applied so far
"""

from __future__ import annotations

from .parameter_commands import Admissible, ParameterCommands, parameter_port

BRACE_TOPIC = "/brace/parameters"


class Ros2BraceCommands(ParameterCommands):
    type_name = "ros2_brace_commands"
    TOPIC, NODE = BRACE_TOPIC, "snakesim_brace_commands"
    PARAMETERS = {"target_force": Admissible("N", 0.0, strict=True), "climb_speed": Admissible("rad/s"),
                  "descent_speed": Admissible("m/s", 0.0)}

    target_force = parameter_port("N")
    climb_speed = parameter_port("rad/s")
    descent_speed = parameter_port("m/s")
