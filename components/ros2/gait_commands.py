"""ROS 2 gait commands: the shape gaits' parameters (serpenoid_gait, helical_gait) from an autonomy stack.

A discrete source (give it a ``rate``; ``snakesim run --ros2`` adds it at the command rate, 100 Hz,
for the first serpenoid_gait or helical_gait whose command inputs the scene leaves free, and wires
each output into the gait's input of the same name). Validation and hold: :mod:`.parameter_commands`.

    /gait/parameters   rcl_interfaces/ParameterEvent   changed_parameters (and new_parameters): the
                                                       parameters to set, by name; deleted_parameters:
                                                       names given back to the scene's value

From a shell::

    ros2 topic pub --once /gait/parameters rcl_interfaces/msg/ParameterEvent \
        "{changed_parameters: [{name: frequency, value: {type: 3, double_value: 0.8}}]}"

Parameters (value.type 3 double or 2 integer): ``amplitude`` rad >= 0, ``frequency`` Hz >= 0,
``wavelength`` joints > 0 (serpenoid), ``phase_step`` rad (helical), ``direction`` +1 or −1.
A gait that lacks an input ignores that parameter.

out  amplitude[1] rad, frequency[1] Hz, wavelength[1], phase_step[1] rad, direction[1]  (NaN: not commanded)
     rejected[1]   messages rejected so far
     applied[1]    messages applied so far
"""

from __future__ import annotations

from .parameter_commands import Admissible, ParameterCommands, parameter_port

GAIT_TOPIC = "/gait/parameters"


class Ros2GaitCommands(ParameterCommands):
    type_name = "ros2_gait_commands"
    TOPIC, NODE = GAIT_TOPIC, "snakesim_gait_commands"
    PARAMETERS = {"amplitude": Admissible("rad", 0.0), "frequency": Admissible("Hz", 0.0),
                  "wavelength": Admissible("joints", 0.0, strict=True), "phase_step": Admissible("rad"),
                  "direction": Admissible(values=(1.0, -1.0))}

    amplitude = parameter_port("rad")
    frequency = parameter_port("Hz")
    wavelength = parameter_port("1")
    phase_step = parameter_port("rad")
    direction = parameter_port("1")
