"""Result objects: what a run, a budget, a sweep and a diagnosis look like in a notebook.

Each holds what its command computed (the content of the JSON files the command writes, and for a
mission the engine's :class:`~sins_sim.simulation.sins.SinsResult`) with ``to_pandas()``, a
``plot()`` that hands off to :mod:`sins_sim.plots` (imported lazily, so this room stays light) and,
for the mission and the sweep, ``to_xarray()``.

This room sits below the commands (``jobs -> results -> config``): the commands make these objects
(:func:`sins_sim.run`, :func:`sins_sim.load`, ``run_budget``, ``run_sweep``, ``diagnose``) and the
objects never import a command; a mission's ``save`` hands off to the command that made it
(:class:`sins_sim.jobs.notebook.RunOrigin`).
"""

from __future__ import annotations

from sins_sim.results.budget import BudgetResult
from sins_sim.results.diagnosis import DiagnosisResult
from sins_sim.results.identify import IdentifyResult
from sins_sim.results.mission import FIGURE_KINDS, SERIES_COLUMNS, MissionResult, StoredRun
from sins_sim.results.sweep import SweepResult

__all__ = ["MissionResult", "StoredRun", "BudgetResult", "SweepResult", "DiagnosisResult", "IdentifyResult",
           "FIGURE_KINDS",
           "SERIES_COLUMNS"]
