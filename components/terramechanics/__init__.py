"""Terramechanics: screws and body links on deformable soil (Bekker–Wong, Mohr–Coulomb, Janosi–Hanamoto;
contact.py, body_contact.py), the soil bin's drawbar carriage (drawbar_carriage.py), and a rigid wheel for
the textbook check (wheel.py)."""

from .body_contact import SoilBodyContact
from .contact import TerramechanicsContact
from .drawbar_carriage import DrawbarCarriage

#: the components this package registers (components/plugin.py)
TERRAMECHANICS = (TerramechanicsContact, SoilBodyContact, DrawbarCarriage)

__all__ = ["TerramechanicsContact", "SoilBodyContact", "DrawbarCarriage", "TERRAMECHANICS"]
