"""sins-sim: a strapdown INS on mechanically dithered ring laser gyros, down to the suspension physics.

Conventions (the full page, with every column name: ``docs/conventions.md``)

* **Frames.** Body axes x, y, z are the three gyros' sensitive axes and the accelerometers' (for a
  vehicle x forward, y right, z down); the navigation frame is local-level north-east-down (NED) on
  WGS-84; gyros measure rotation with respect to inertial space. For each gyro channel
  (docs/theory/suspension.md) ``phi_sins`` is the block's angle about the gyro's sensitive axis, ``phi_rlg``
  the RLG body's angle w.r.t. inertial space, and ``delta = phi_rlg - phi_sins`` the dither
  suspension's deflection.
* **Quaternions** are Hamilton, scalar first ``[q0, q1, q2, q3]``, body to navigation
  (``v_n = q v_b q*``). **Euler angles** are roll, pitch, yaw of the body against NED in the 3-2-1
  sequence (yaw about down first), yaw from north towards east, ``|pitch| < 90 deg``.
* **Attitude errors.** ``phi`` is the rotation vector of ``q_est q_true*`` in NED, the attitude
  against the true NED frame (``C_nb_est = (I + [phi x]) C_nb_true``); ``psi = phi + (dlon cos L,
  -dlat, -dlon sin L)`` is taken against the NED frame at the computed position (Benson 1975).
* **Increments** are raw and uncompensated: the gyro increment is the body's angle w.r.t. inertial
  space over one filter sample (vehicle, Earth and transport rate and the block's own motion), the
  accelerometer increment the integral of specific force over the same sample, both per body axis
  and with the unit's sensor errors in them. Coning and sculling corrections live inside the
  strapdown algorithm. The filter ``raw`` is the decimated readout with the dither still in it.

Units: SI inside, angles in rad, rates in rad/s, frequencies in Hz (``omega`` in rad/s),
voltages in V. arcsec / arcmin / deg and deg/h appear only at the edges (configuration, plots,
reports), and a key always carries its unit (``amplitude_arcmin``, ``rate_deg_s``, ``time_s``);
see :mod:`sins_sim.units`.

Layers (imports point one way, checked by import-linter, contracts in ``pyproject.toml``)::

    cli -> bench -> jobs -> results -> config -> identification -> simulation -> plots
        -> {models, filters, navigation} -> io -> _kernels -> {earth, units}

``jobs`` holds the commands (run, budget, sweep, reproduce, ...); ``results`` below them the result
objects the commands return (tables, figures, files); ``config`` below those turns YAML files into the
engine's inputs (schemas, loaders, :class:`~sins_sim.config.errors.ConfigError`) and never imports a
command.

Public API (imported lazily, so ``import sins_sim`` stays light and never loads matplotlib):

* the engine: :func:`simulate_sins`, :class:`ImuConfig`, :class:`NavSettings`,
  :func:`simulate_channel`, :class:`ChannelConfig`;
* the filters: :class:`CorrectingFilter`, :class:`CorrectingFilterDesign`, :func:`correct`,
  :class:`Eliminator`, :class:`EliminatorDesign`;
* the physics: :class:`SuspensionParams`, :data:`PAPER_SUSPENSION`;
* navigation: :class:`StrapdownNavigator`;
* configuration: :func:`load_imu`, :func:`load_scenario` (a file or a dict), :func:`load_yaml` (a YAML file as
  the loaders read it: YAML 1.2 numbers such as ``7.58e5`` are numbers), :func:`run_scenario`;
* a unit's log at rest: :func:`identify` (noise terms, spectral lines, rest biases, bias steps, temperature
  coefficients, the twin's ``sensors:`` section, the twin run beside the log and where they part);
* notebooks: :func:`run` (a scenario file, dict or object -> :class:`MissionResult` with tables,
  figures and ``save``), :func:`load` (a result folder -> :class:`MissionResult`, :class:`BudgetResult`
  or :class:`SweepResult`), :func:`sweep_run` (one run of a sweep -> :class:`MissionResult`);
  :class:`DiagnosisResult` is what ``diagnose`` returns, :class:`IdentifyResult` what :func:`identify` returns.
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
    "load_imu": "sins_sim.config.imu",
    "load_scenario": "sins_sim.config.scenario",
    "load_yaml": "sins_sim.config.yaml_io",
    "run_scenario": "sins_sim.jobs.run",
    "identify": "sins_sim.jobs.identify",
    "run": "sins_sim.jobs.notebook",
    "load": "sins_sim.jobs.notebook",
    "sweep_run": "sins_sim.jobs.notebook",
    "MissionResult": "sins_sim.results",
    "BudgetResult": "sins_sim.results",
    "SweepResult": "sins_sim.results",
    "DiagnosisResult": "sins_sim.results",
    "IdentifyResult": "sins_sim.results",
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
