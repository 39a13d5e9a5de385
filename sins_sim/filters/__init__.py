"""Dither-removal filters: the correcting filter (eq. 5) and the elliptic eliminator."""

from sins_sim.filters.correcting import CorrectingFilter, CorrectingFilterDesign, correct
from sins_sim.filters.eliminator import Eliminator, EliminatorDesign, eliminate

__all__ = ["CorrectingFilter", "CorrectingFilterDesign", "correct", "Eliminator", "EliminatorDesign", "eliminate"]
