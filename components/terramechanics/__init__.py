"""Terramechanics: screws on deformable soil (Bekker–Wong, Mohr–Coulomb, Janosi–Hanamoto; contact.py)."""

from .contact import TerramechanicsContact

__all__ = ["TerramechanicsContact"]
