"""sins-sim: a strapdown INS on mechanically dithered ring laser gyros, down to the suspension physics.

Frames and signals (reference-model.md): for each gyro channel, ``phi_sins`` is the block's
angle about the gyro's sensitive axis, ``phi_rlg`` the RLG body's angle w.r.t. inertial space,
and ``delta = phi_rlg - phi_sins`` the dither suspension's deflection. The navigation frame is
local-level north-east-down on WGS-84; attitude quaternions are Hamilton, scalar first, body to
navigation.

Units: SI inside, angles in rad, rates in rad/s, frequencies in Hz (``omega`` in rad/s),
voltages in V. arcsec / arcmin / deg and deg/h appear only at the edges (configuration, plots,
reports); see :mod:`sins_sim.units`.

Layers (imports point one way, checked by import-linter, contracts in ``pyproject.toml``)::

    cli -> bench -> jobs -> identification -> simulation -> plots
        -> {models, filters, navigation} -> io -> _kernels -> {earth, units}

Public API (imported lazily, so ``import sins_sim`` stays light and never loads matplotlib):

* the engine: :func:`simulate_sins`, :class:`ImuConfig`, :class:`NavSettings`,
  :func:`simulate_channel`, :class:`ChannelConfig`;
* the filters: :class:`CorrectingFilter`, :class:`CorrectingFilterDesign`, :func:`correct`,
  :class:`Eliminator`, :class:`EliminatorDesign`;
* the physics: :class:`SuspensionParams`, :data:`PAPER_SUSPENSION`;
* navigation: :class:`StrapdownNavigator`;
* configuration: :func:`load_imu`, :func:`load_scenario` (a file or a dict), :func:`run_scenario`;
* notebooks: :func:`run` (a scenario file, dict or object -> :class:`MissionResult` with tables,
  figures and ``save``), :func:`load` (a result folder -> :class:`MissionResult`).
"""

from __future__ import annotations

import importlib

from sins_sim._version import __version__

_API = {
    "simulate_sins": "sins_sim.simulation.sins",
    "ImuConfig": "sins_sim.simulation.sins",
    "NavSettings": "sins_sim.simulation.sins",
    "SinsResult": "sins_sim.simulation.sins",
    "simulate_channel": "sins_sim.simulation.channel",
    "ChannelConfig": "sins_sim.simulation.channel",
    "CorrectingFilter": "sins_sim.filters.correcting",
    "CorrectingFilterDesign": "sins_sim.filters.correcting",
    "correct": "sins_sim.filters.correcting",
    "Eliminator": "sins_sim.filters.eliminator",
    "EliminatorDesign": "sins_sim.filters.eliminator",
    "SuspensionParams": "sins_sim.models.suspension",
    "PAPER_SUSPENSION": "sins_sim.models.suspension",
    "StrapdownNavigator": "sins_sim.navigation.strapdown",
    "load_imu": "sins_sim.jobs.imu",
    "load_scenario": "sins_sim.jobs.scenario",
    "run_scenario": "sins_sim.jobs.run",
    "run": "sins_sim.jobs.results",
    "load": "sins_sim.jobs.results",
    "MissionResult": "sins_sim.jobs.results",
}

__all__ = sorted(_API) + ["__version__"]


def __getattr__(name):
    """Import a public name on first use (PEP 562)."""
    if name in _API:
        value = getattr(importlib.import_module(_API[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'sins_sim' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
