"""Dither-removal filters: the correcting filter (eq. 5) and the elliptic eliminator.

The names below are imported on first use (PEP 562), so that importing ``sins_sim.filters.registry``
(the filter names a configuration file is checked against) does not import scipy and numba: a
configuration error is reported before the heavy imports.
"""

import importlib

__all__ = ["CorrectingFilter", "CorrectingFilterDesign", "correct", "Eliminator", "EliminatorDesign", "eliminate"]

_WHERE = {"CorrectingFilter": "correcting", "CorrectingFilterDesign": "correcting", "correct": "correcting",
          "Eliminator": "eliminator", "EliminatorDesign": "eliminator", "eliminate": "eliminator"}


def __getattr__(name):
    if name in _WHERE:
        return getattr(importlib.import_module(f"sins_sim.filters.{_WHERE[name]}"), name)
    raise AttributeError(f"module 'sins_sim.filters' has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + list(_WHERE))
