"""Terramechanics: screws and body links on deformable soil (Bekker–Wong, Mohr–Coulomb, Janosi–Hanamoto;
contact.py, body_contact.py), and a rigid wheel for the textbook check (wheel.py)."""

from .body_contact import SoilBodyContact
from .contact import TerramechanicsContact

#: the components this package registers (components/plugin.py)
TERRAMECHANICS = (TerramechanicsContact, SoilBodyContact)

__all__ = ["TerramechanicsContact", "SoilBodyContact", "TERRAMECHANICS"]
