"""A sweep as a Python object (:class:`SweepResult`) and the vocabulary of its table (``runs.parquet``).

The table has one row per run (unit x scenario): the columns that name the run, the drawn parameters
(``param.*``) and, per filter, ``<filter>.<metric>`` for every :data:`METRICS` entry (the unit in the
metric's name) and ``<filter>.status``. The sweep command (:mod:`sins_sim.jobs.sweep`) fills it and
summarises it; the names live here, with the object that reads them, so that both rooms share one
definition and this one never imports a command.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from sins_sim.config.errors import ConfigError
from sins_sim.results._folder import read_json

__all__ = ["SweepResult", "METRICS", "HEADLINE_METRICS", "CONFIDENCE", "metric_filters", "quantile_n_required"]

_NED = ("north", "east", "down")
#: Per-filter metric columns (``<filter>.<metric>``) with their axis labels (units in the names).
METRICS = {
    "horizontal_position_error_m_final": "final horizontal position error (m)",
    "horizontal_position_error_m_max": "largest horizontal position error (m)",
    "vertical_position_error_m_final": "final vertical position error (m)",
    "velocity_error_m_s_final": "final velocity error (m/s)",
    "velocity_error_m_s_max": "largest velocity error (m/s)",
    **{f"attitude_error_arcsec_rms_{a}": f"RMS attitude error about {a} (arcsec)" for a in _NED},
    "attitude_error_arcsec_rms_total": "RMS attitude error, root sum of squares N, E, D (arcsec)",
    **{f"attitude_error_arcsec_final_{a}": f"final attitude error about {a} (arcsec)" for a in _NED},
    "cep_rate_nmi_h": "CEP rate (nmi/h)",
    **{f"attitude_drift_deg_h_{a}": f"effective attitude drift about {a} (deg/h; only where a ramp explains it)"
       for a in _NED},
    **{f"gyro_drift_deg_h_{a}": f"gyro drift of the filter's output, axis {a} (deg/h; only where a ramp explains it)"
       for a in ("x", "y", "z")},
    "excess_over_ideal_horizontal_m": "final horizontal error beyond ideal's: norm of the vector difference (m)",
    "event_step_arcsec_max": "largest attitude step across a shock or turn (arcsec)",
    **{f"gyro_error_rms_arcsec_{a}": f"RMS gyro-angle error, axis {a} (arcsec)" for a in ("x", "y", "z")},
}
#: The metrics summarised in the plots (all of :data:`METRICS` are in ``summary.json``).
HEADLINE_METRICS = ("horizontal_position_error_m_final", "velocity_error_m_s_final",
                    "attitude_error_arcsec_rms_total", "event_step_arcsec_max")
#: Confidence level of every interval of the sweep's summary (two-sided, equal tails).
CONFIDENCE = 0.95


def metric_filters(table) -> list:
    """The filters with metric columns in ``table``, in column order."""
    out = []
    for col in table.columns:
        name, _, metric = col.partition(".")
        if metric == "status" and name not in out:
            out.append(name)
    return out


def quantile_n_required(q: float, confidence: float = CONFIDENCE) -> int:
    """Fewest values whose order statistics bracket the ``q`` quantile with an equal-tailed two-sided interval.

    The smallest value is a lower confidence bound at ``1 - (1-confidence)/2`` when ``(1-q)^n <= (1-confidence)/2``
    and the largest an upper bound when ``q^n <= (1-confidence)/2`` (:mod:`sins_sim.jobs.sweep.summary`'s docstring).

    Parameters
    ----------
    q : float
        The quantile's probability, in (0, 1).
    confidence : float
        Two-sided confidence level.

    Returns
    -------
    int
        The smallest sample size that supports the quantile.

    Examples
    --------
    >>> [quantile_n_required(q) for q in (0.5, 0.95, 0.99)]
    [6, 72, 368]
    """
    tail = 0.5 * (1.0 - confidence)
    worst = max(q, 1.0 - q)
    n = max(1, math.ceil(math.log(tail) / math.log(worst)))
    while worst ** n > tail:  # guard the rounding of the logarithms both ways
        n += 1
    while n > 1 and worst ** (n - 1) <= tail:
        n -= 1
    return n


class SweepResult(dict):
    """A sweep (:func:`sins_sim.jobs.sweep.run_sweep`): its dict (``summary``, ``table``, counts) with
    :meth:`to_pandas` (one row per run), :meth:`to_xarray` (a ``run`` dimension) and :meth:`plot`.
    A run's time series are not kept: :func:`sins_sim.sweep_run` recomputes one run."""

    def to_pandas(self):
        """``runs.parquet``: one row per run (unit x scenario), the drawn parameters (``param.*``) and per
        filter its metrics (``<filter>.<metric>``, the unit in the metric's name)."""
        return self["table"].copy()

    def to_xarray(self):
        """The runs as a Dataset with dimensions ``run`` and ``filter``.

        Each per-filter metric (``<filter>.<metric>`` columns) becomes one variable ``<metric>`` on
        ``(run, filter)``; every other column (``unit``, ``scenario``, ``seed``, ``param.*``, ...) a
        variable on ``run``. Percentiles over the population are then
        ``ds.groupby("scenario").quantile([0.05, 0.5, 0.95], dim="run")``. Attributes: the sweep's name and
        sins-sim's version.

        What a run keeps: its scalars only, the :data:`METRICS` per filter (final and largest horizontal
        and vertical position error, final and largest velocity error, RMS and final attitude error per
        NED axis, CEP rate, drifts where a ramp explains them, the largest step across an event, RMS
        gyro-angle error per axis), its status, its drawn parameters, seed and warnings. An envelope over
        the population is one of these, per scenario (or against a drawn parameter). The sweep does not
        keep time series (a sweep of 400 one-hour runs would hold them all); for an envelope over time of
        chosen runs, :func:`sins_sim.sweep_run` runs each again as a
        :class:`~sins_sim.results.MissionResult` with its stored series, the row's metrics exactly.
        """
        import xarray as xr

        from sins_sim._version import __version__

        table = self["table"].reset_index(drop=True)
        filters = metric_filters(table)
        data, metrics = {}, {}
        for col in table.columns:
            name, dot, metric = col.partition(".")
            if dot and name in filters:
                metrics.setdefault(metric, {})[name] = table[col].to_numpy()
            else:
                data[col] = ("run", table[col].to_numpy())
        for metric, per in metrics.items():
            cols = [per.get(f, np.full(len(table), np.nan)) for f in filters]
            data[metric] = (("run", "filter"), np.stack(cols, axis=1))
        return xr.Dataset(data, coords={"run": np.arange(len(table)), "filter": np.array(filters, dtype=str)},
                          attrs={"sweep": str(self.get("name", "")), "sins_sim_version": __version__})

    def plot(self):
        """``distributions.png``'s figure (the ECDF of the headline metrics per filter), returned."""
        from sins_sim.plots.sweep import plot_distributions

        table = self["table"]
        labels = list(dict.fromkeys(table["scenario"])) if len(table) else []
        fig = plot_distributions(table, {m: METRICS[m] for m in HEADLINE_METRICS}, metric_filters(table), labels,
                                 None, f"{self.get('name', 'sweep')}: distribution over "
                                       f"{table['unit'].nunique() if len(table) else 0} units",
                                 p95_min_n=quantile_n_required(0.95))
        if fig is None:
            raise ValueError("plot: the sweep has no positive finite headline metric to draw")
        return fig

    @classmethod
    def from_folder(cls, folder) -> "SweepResult":
        """A sweep folder's ``runs.parquet`` and ``summary.json``."""
        import pandas as pd

        folder = Path(folder)
        if not (folder / "runs.parquet").is_file():
            raise ConfigError(f"load: {folder} has no runs.parquet (not a finished sweep)")
        name = read_json(folder / "sweep.json", "sweep").get("name") if (folder / "sweep.json").is_file() else None
        return cls(name=name, summary=read_json(folder / "summary.json", "sweep"),
                   table=pd.read_parquet(folder / "runs.parquet"))
