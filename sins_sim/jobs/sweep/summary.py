"""``summary.json``: how many runs, how many failed, and the percentiles of every metric per filter.

::

    {"runs": 400, "failed": 0,
     "percentiles": {metric: {filter: {"p50": .., "p95": .., "p99": .., "n": ..}}},     # over every run
     "by_scenario": {label: {"runs": .., "failed": .., "percentiles": {...}}},
     "drivers": {label: {metric: {filter: [{"parameter": .., "spearman": ..}, ...]}}}}

Percentiles are numpy's (linear interpolation between order statistics) over the runs where the
metric is finite (``n`` of them; a diverged filter or a metric a scenario does not define, such as a
step without an event, is left out). With fewer than 100 runs p99 interpolates between the two
largest values. ``drivers`` ranks the drawn parameters by the Spearman rank correlation of the metric
with each (largest magnitude first, the five strongest): which parameter drives the tail.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.jobs.sweep.tasks import HEADLINE_METRICS, METRICS, PARAM_PREFIX

__all__ = ["summarize", "metric_filters", "parameter_names", "spearman"]

_QUANTILES = {"p50": 50.0, "p95": 95.0, "p99": 99.0}


def metric_filters(table) -> list:
    """The filters with metric columns in ``table``, in column order."""
    out = []
    for col in table.columns:
        name, _, metric = col.partition(".")
        if metric == "status" and name not in out:
            out.append(name)
    return out


def parameter_names(table) -> list:
    """The drawn parameters that vary over ``table`` (``f0_ppm.x``, ...)."""
    cols = [c for c in table.columns if c.startswith(PARAM_PREFIX)]
    return [c[len(PARAM_PREFIX):] for c in cols if table[c].nunique() > 1]


def _per_metric(table, filters, metrics, stat) -> dict:
    """``{metric: {filter: stat(column)}}`` over the columns ``FILTER.METRIC`` present in ``table``;
    ``stat`` returns None where a column has nothing to report (then the entry is left out)."""
    out = {}
    for metric in metrics:
        per = {}
        for f in filters:
            col = f"{f}.{metric}"
            if col in table:
                value = stat(table[col])
                if value is not None:
                    per[f] = value
        if per:
            out[metric] = per
    return out


def _percentiles(table, filters) -> dict:
    def stat(column):
        x = column.to_numpy(dtype=float)
        x = x[np.isfinite(x)]
        if not x.size:
            return None
        return {**{k: float(np.percentile(x, q)) for k, q in _QUANTILES.items()}, "n": int(x.size)}

    return _per_metric(table, filters, METRICS, stat)


def spearman(x, y) -> float:
    """Spearman rank correlation (``scipy.stats.spearmanr``) of two samples over the pairs where both are
    finite (NaN if fewer than 3 pairs or either sample is constant)."""
    from scipy.stats import spearmanr

    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 3 or np.ptp(x[ok]) == 0.0 or np.ptp(y[ok]) == 0.0:
        return math.nan
    return float(spearmanr(x[ok], y[ok]).statistic)


def _drivers(table, filters, params) -> dict:
    def stat(column):
        ranks = [(p, spearman(table[PARAM_PREFIX + p], column)) for p in params]
        ranks = [(p, r) for p, r in ranks if math.isfinite(r)]
        ranks.sort(key=lambda pr: -abs(pr[1]))
        return [{"parameter": p, "spearman": round(r, 4)} for p, r in ranks[:5]] if ranks else None

    return _per_metric(table, filters, HEADLINE_METRICS, stat)


def summarize(table, failures: list, labels: list) -> dict:
    """The summary of a sweep's table (one row per finished run) and its failure records."""
    filters = metric_filters(table) if len(table) else []
    params = parameter_names(table) if len(table) else []
    out = {"runs": int(len(table)), "failed": len(failures),
           "percentiles": _percentiles(table, filters) if len(table) else {}, "by_scenario": {}, "drivers": {}}
    for label in labels:
        sub = table[table["scenario"] == label] if len(table) else table
        out["by_scenario"][label] = {"runs": int(len(sub)),
                                     "failed": sum(1 for r in failures if r.get("scenario") == label),
                                     "percentiles": _percentiles(sub, filters) if len(sub) else {}}
        if len(sub) >= 3 and params:
            out["drivers"][label] = _drivers(sub, filters, params)
    return out
