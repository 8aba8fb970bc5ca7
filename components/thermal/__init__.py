"""Heated screws on ice (issue 28): screw temperature and melt-in, the groove's walls, ice friction of
temperature and speed, the heater thermostat, the thermocouple and the melt-in mobility judge. Each is an
ordinary component wired to the screw contact's law ports (docs/thermal.md)."""

from .groove_drag import GrooveDrag
from .ice_friction import IceFriction
from .melt_watch import MeltClimbWatch
from .screw_heat import ScrewHeat
from .thermocouple import Thermocouple
from .thermostat import Thermostat

THERMAL = (ScrewHeat, GrooveDrag, IceFriction, Thermostat, Thermocouple, MeltClimbWatch)
