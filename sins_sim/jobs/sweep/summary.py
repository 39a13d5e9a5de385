"""``summary.json``: runs, failures, percentiles with confidence intervals, and the drivers that survive a test.

::

    {"runs": 400, "failed": 0,
     "methods": {"percentiles": {...}, "drivers": {...}},          # how every number below was made
     "percentiles": {metric: {filter: {"n": 200,
                                       "p50": {"value": .., "ci95": [lo, hi], "ci95_order_statistic": [lo, hi],
                                               "supported": true, "n": 200},
                                       "p99": {"supported": false, "n_required": 368, "n": 200}}}},
     "by_scenario": {label: {"runs": .., "failed": .., "percentiles": {...}}},
     "drivers": {label: {metric: {filter: {"n": 200, "parameters_tested": 55,
                                           "significant": [{"parameter": "f0_ppm.z", "spearman": 0.83,
                                                            "p": 0.0001, "p_adjusted": 0.0001, "n": 200}]}}}}}

Values are in the metric's own unit (the unit is in the metric's name: ``_m``, ``_m_s``, ``_arcsec``, ...).

**Percentiles** (``_QUANTILES``: p50, p95, p99) are over the runs where the metric is finite; ``n`` counts
them (a diverged filter, or a metric a scenario does not define, such as a step without an event, is left
out). A quantile is reported only where the sample supports it: where the distribution-free two-sided 95 %
confidence interval of the quantile from order statistics exists (Hahn & Meeker, *Statistical Intervals*,
1991, sec. 5.2; David & Nagaraja, *Order Statistics*, 2003, sec. 7.1). With ``B ~ Binomial(n, q)`` the
number of the ``n`` values below the ``q`` quantile ``x_q``, ``P(X_(l) <= x_q < X_(u)) = P(l <= B <= u-1)``;
the equal-tailed interval puts at most 2.5 % on each side, which needs ``(1-q)^n <= 0.025`` (the smallest
value is a lower bound) and ``q^n <= 0.025`` (the largest is an upper bound): n >= 6 for p50, 72 for p95
and 368 for p99 (:func:`quantile_n_required`). Below that the entry holds ``supported: false``, ``n`` and
``n_required`` and no value: a p99 of 10 units is the largest unit and says nothing of the 99th percentile.

A supported quantile holds

* ``value``: numpy's percentile (linear interpolation between order statistics, Hyndman & Fan type 7);
* ``ci95``: the percentile bootstrap interval (``scipy.stats.bootstrap``, ``method="percentile"``,
  :data:`BOOTSTRAP_RESAMPLES` resamples, a fixed seed so that the summary is reproducible; Efron &
  Tibshirani, *An Introduction to the Bootstrap*, 1993, ch. 13), the interval asked for;
* ``ci95_order_statistic``: ``[X_(l), X_(u)]``, the distribution-free interval above, whose coverage is at
  least 95 % for any continuous distribution. Near the support limit the percentile bootstrap of an extreme
  quantile is too short (its resamples cannot exceed the sample maximum); where the two differ, the
  order-statistic interval is the one to trust.

**Drivers** (``drivers``): for every scenario, headline metric (:data:`~.tasks.HEADLINE_METRICS`) and
filter, the Spearman rank correlation of the metric with every drawn parameter over the units where the
metric is finite (``n``). Columns that do not vary (a metric identical over the units, a parameter
constant within the scenario) are not tested. The tests are one family over the whole summary (every
scenario, metric, filter and parameter: ``methods.drivers.tests``), corrected for multiplicity by the
Westfall & Young step-down maxT permutation procedure (Westfall & Young, *Resampling-Based Multiple
Testing*, 1993, algorithm 4.1; Ge, Dudoit & Speed, *TEST* 12, 2003, box 2) with
:data:`DRIVER_PERMUTATIONS` random permutations of the units, one permutation shared by every test. It
controls the family-wise error rate (the chance of reporting any parameter that does not act) at
:data:`DRIVER_ALPHA` in the strong sense. Chosen over Holm on ``scipy.stats.spearmanr``'s p-values because
(1) spearmanr's p-value is a Student-t approximation that is 1.5-2.9 times too small at p ~ 1e-4 for
10-30 units (measured against 2-4 million random permutations of the ranks), exactly where Holm's thresholds over a
family of a few thousand tests lie; (2) the permutation null is exact for ties (a grid parameter) and
keeps the dependence between the metrics and filters, which Holm can only bound. Only the drivers with
``p_adjusted <= alpha`` are listed, with ``spearman`` (rho, ``scipy.stats.spearmanr``), ``p`` (the
test's own permutation p-value, unadjusted) and ``p_adjusted``; both p-values are ``(1 + count) /
(1 + permutations)`` (Phipson & Smyth, *Stat. Appl. Genet. Mol. Biol.* 9, 2010), so their smallest value
``1 / (1 + permutations)`` reads "at most". An empty ``significant`` list means no significant driver at
that ``n``. The statistic of the maxT procedure is ``|rho| sqrt(n - 1)`` (rho's null standard deviation
is ``1 / sqrt(n - 1)``), so that tests over different ``n`` weigh alike.
"""

from __future__ import annotations

import inspect
import math

import numpy as np

from sins_sim.jobs.sweep.tasks import PARAM_PREFIX
from sins_sim.results.sweep import CONFIDENCE, HEADLINE_METRICS, METRICS, metric_filters, quantile_n_required

__all__ = ["summarize", "metric_filters", "parameter_names", "quantile_n_required",
           "order_statistic_interval", "quantile_summary", "driver_tests", "CONFIDENCE", "DRIVER_ALPHA",
           "BOOTSTRAP_RESAMPLES", "DRIVER_PERMUTATIONS"]

#: The quantiles of ``percentiles`` (key -> probability).
_QUANTILES = {"p50": 0.50, "p95": 0.95, "p99": 0.99}
#: Resamples of the percentile bootstrap (Efron & Tibshirani 1993, ch. 13: 1000-2000 for a percentile interval).
BOOTSTRAP_RESAMPLES = 2000
#: Random permutations of the units behind the drivers' p-values (smallest p-value 1 / (1 + this)).
DRIVER_PERMUTATIONS = 4999
#: Family-wise error rate of the drivers.
DRIVER_ALPHA = 0.05
#: Fewest units with a finite metric for a rank correlation to be tested.
_MIN_PAIRS = 3
#: Seeds of the resampling (fixed: the same table gives the same summary, and resumed sweeps compare equal).
_BOOTSTRAP_SEED = 20260
_PERMUTATION_SEED = 20261


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


# --- percentiles ------------------------------------------------------------------------------------------------
def order_statistic_interval(n: int, q: float, confidence: float = CONFIDENCE) -> tuple[int, int] | None:
    """Ranks of the distribution-free equal-tailed confidence interval of a quantile (Hahn & Meeker 1991, 5.2).

    Parameters
    ----------
    n : int
        Sample size.
    q : float
        The quantile's probability, in (0, 1).
    confidence : float
        Two-sided confidence level; each tail holds at most half of ``1 - confidence``.

    Returns
    -------
    tuple of int or None
        1-based ranks ``(l, u)`` of ``[X_(l), X_(u)]`` with ``P(B < l) <= tail`` and ``P(B >= u) <= tail``,
        ``B ~ Binomial(n, q)``, ``l`` as large and ``u`` as small as that allows; None when the order
        statistics cannot bracket the quantile (``n < quantile_n_required(q)``).
    """
    from scipy.stats import binom

    tail = 0.5 * (1.0 - confidence)
    k = np.arange(n)
    low = np.flatnonzero(binom.cdf(k, n, q) <= tail)   # l - 1 with P(B <= l - 1) <= tail
    high = np.flatnonzero(binom.sf(k, n, q) <= tail)   # u - 1 with P(B >= u) <= tail
    if not low.size or not high.size:
        return None
    return int(low[-1]) + 1, int(high[0]) + 1


def _bootstrap(x: np.ndarray, qs: list) -> np.ndarray:
    """Percentile-bootstrap intervals of numpy's percentiles ``qs`` (probabilities) of ``x``: shape (len(qs), 2)."""
    from scipy.stats import bootstrap

    if np.ptp(x) == 0.0:
        return np.repeat(np.full((len(qs), 1), x[0]), 2, axis=1)

    def stat(sample, axis):  # one output per quantile, along the first axis (scipy's convention)
        return np.percentile(sample, [100.0 * q for q in qs], axis=axis)

    # scipy names the generator rng from 1.15 on, random_state before (the oldest allowed scipy is 1.11)
    seed_kw = "rng" if "rng" in inspect.signature(bootstrap).parameters else "random_state"
    res = bootstrap((x,), stat, n_resamples=BOOTSTRAP_RESAMPLES, vectorized=True, method="percentile",
                    confidence_level=CONFIDENCE, **{seed_kw: np.random.default_rng(_BOOTSTRAP_SEED)})
    ci = res.confidence_interval
    return np.stack([np.atleast_1d(ci.low), np.atleast_1d(ci.high)], axis=1)


def quantile_summary(values) -> dict | None:
    """The ``percentiles`` entry of one column (module docstring).

    Parameters
    ----------
    values : array_like
        The column; NaN and inf are left out (``n`` counts the rest).

    Returns
    -------
    dict or None
        ``{"n": n, "p50": {...}, "p95": {...}, "p99": {...}}``; None without a finite value.
    """
    x = np.asarray(values, dtype=float)
    x = np.sort(x[np.isfinite(x)])
    n = int(x.size)
    if not n:
        return None
    out: dict = {"n": n}
    supported = {}
    for key, q in _QUANTILES.items():
        ranks = order_statistic_interval(n, q)
        if ranks is None:
            out[key] = {"supported": False, "n_required": quantile_n_required(q), "n": n}
        else:
            supported[key] = (q, ranks)
    if supported:
        ci = _bootstrap(x, [q for q, _ in supported.values()])
        for (key, (q, (lo, hi))), (b_lo, b_hi) in zip(supported.items(), ci):
            out[key] = {"value": float(np.percentile(x, 100.0 * q)), "ci95": [float(b_lo), float(b_hi)],
                        "ci95_order_statistic": [float(x[lo - 1]), float(x[hi - 1])], "supported": True, "n": n}
    return {"n": n, **{k: out[k] for k in _QUANTILES}}


def _percentiles(table, filters) -> dict:
    return _per_metric(table, filters, METRICS, lambda column: quantile_summary(column.to_numpy(dtype=float)))


# --- drivers ----------------------------------------------------------------------------------------------------
def _zranks(a: np.ndarray, axis: int) -> np.ndarray:
    """Average ranks along ``axis``, centred and scaled to unit norm (so a dot product is Spearman's rho);
    a constant column becomes NaN."""
    from scipy.stats import rankdata

    r = rankdata(a, axis=axis)
    r = r - r.mean(axis=axis, keepdims=True)
    norm = np.sqrt((r * r).sum(axis=axis, keepdims=True))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(norm > 0.0, r / np.where(norm > 0.0, norm, 1.0), np.nan)


def driver_tests(table, labels, filters=None, params=None, metrics=HEADLINE_METRICS,
                 permutations: int = DRIVER_PERMUTATIONS, seed: int = _PERMUTATION_SEED) -> list:
    """Every driver test of a sweep's table, corrected as one family (module docstring).

    Parameters
    ----------
    table : pandas.DataFrame
        One row per run: ``scenario``, ``unit``, ``param.*`` and ``FILTER.METRIC`` columns.
    labels : list of str
        The scenarios to test.
    filters, params : list, optional
        Default: :func:`metric_filters` and :func:`parameter_names` of ``table``.
    metrics : sequence of str
        The metrics tested (default the headline metrics).
    permutations : int
        Random permutations of the units.
    seed : int
        Seed of the permutations.

    Returns
    -------
    list of dict
        One record per test: ``scenario``, ``metric``, ``filter``, ``parameter``, ``n``, ``spearman``,
        ``p`` (unadjusted permutation p-value), ``p_adjusted`` (step-down maxT) and ``significant``
        (``p_adjusted <= DRIVER_ALPHA``), ``p_resolution`` (``1 / (1 + permutations)``, the smallest p-value).
    """
    if not len(table):
        return []
    filters = metric_filters(table) if filters is None else filters
    params = parameter_names(table) if params is None else params
    if not params:
        return []
    units = np.array(sorted(table["unit"].unique()))
    index = {u: i for i, u in enumerate(units)}
    # the drawn parameters belong to the unit (the same in every scenario)
    x = table.groupby("unit")[[PARAM_PREFIX + p for p in params]].first().loc[units].to_numpy(dtype=float)
    # tests grouped by the set of units with a finite metric (one rank matrix of the parameters per group)
    groups: dict = {}
    for label in labels:
        sub = table[table["scenario"] == label]
        rows = np.array([index[u] for u in sub["unit"]], dtype=int)
        for metric in metrics:
            for f in filters:
                col = f"{f}.{metric}"
                if col not in sub:
                    continue
                y = np.full(units.size, np.nan)
                y[rows] = sub[col].to_numpy(dtype=float)
                mask = np.isfinite(y)
                if mask.sum() < _MIN_PAIRS or np.ptp(y[mask]) == 0.0:
                    continue  # a metric that does not vary is not tested
                groups.setdefault(mask.tobytes(), (mask, []))[1].append(((label, metric, f), y[mask]))
    blocks = []  # (mask, zx (n, P), zy (n, K), keys, valid (P, K))
    for mask, cols in groups.values():
        zx = _zranks(x[mask], axis=0)
        zy = _zranks(np.column_stack([y for _, y in cols]), axis=0)
        valid = np.isfinite(zx).all(axis=0)[:, None] & np.isfinite(zy).all(axis=0)[None, :]
        blocks.append((mask, zx, zy, [k for k, _ in cols], valid))
    if not blocks or not any(b[4].any() for b in blocks):
        return []

    def stats(perm_x) -> np.ndarray:
        """|rho| sqrt(n-1) of every valid test, the parameters' units permuted by ``perm_x`` (rows: permutations)."""
        out = []
        for mask, zx, zy, _, valid in blocks:
            n = int(mask.sum())
            if mask.all():  # ranks commute with a permutation: no ranking again
                zxp = zx[perm_x]                                        # (B, n, P)
            else:
                zxp = _zranks(x[perm_x][:, mask], axis=1)
            rho = np.matmul(np.swapaxes(np.nan_to_num(zxp), 1, 2), np.nan_to_num(zy))  # (B, P, K)
            out.append(np.abs(rho[:, valid]) * math.sqrt(n - 1))
        return np.concatenate(out, axis=1)

    t_obs = stats(np.arange(units.size)[None, :])[0]
    order = np.argsort(-t_obs, kind="stable")
    t_sorted = t_obs[order]
    tol = 1e-9 * max(1.0, float(t_sorted.max()))  # ties in floating point count as ties (conservative)
    count_max = np.zeros(t_obs.size)
    count_own = np.zeros(t_obs.size)
    rng = np.random.default_rng(seed)
    chunk = max(1, min(permutations, 2_000_000 // max(1, units.size * x.shape[1])))
    done = 0
    while done < permutations:
        b = min(chunk, permutations - done)
        perm = rng.permuted(np.tile(np.arange(units.size), (b, 1)), axis=1)
        t = stats(perm)
        count_own += (t >= t_obs - tol).sum(axis=0)
        # step-down maxT: the largest statistic among the tests ranked at or below each test
        succ = np.maximum.accumulate(t[:, order][:, ::-1], axis=1)[:, ::-1]
        count_max[order] += (succ >= t_sorted - tol).sum(axis=0)
        done += b
    p_own = (1.0 + count_own) / (1.0 + permutations)
    p_adj = (1.0 + count_max) / (1.0 + permutations)
    p_adj[order] = np.maximum.accumulate(p_adj[order])  # adjusted p-values never fall down the ranking
    records = []
    k = 0  # the statistics run over the blocks, then rho[:, valid] in row-major order, as np.nonzero lists them
    for mask, zx, zy, keys, valid in blocks:
        rho = np.nan_to_num(zx).T @ np.nan_to_num(zy)
        n = int(mask.sum())
        for i, j in zip(*np.nonzero(valid)):
            label, metric, f = keys[j]
            records.append({"scenario": label, "metric": metric, "filter": f, "parameter": params[i], "n": n,
                            "spearman": float(rho[i, j]), "p": float(p_own[k]), "p_adjusted": float(p_adj[k]),
                            "significant": bool(p_adj[k] <= DRIVER_ALPHA), "p_resolution": 1.0 / (1.0 + permutations)})
            k += 1
    return records


def _drivers(table, labels, filters, params, tests) -> dict:
    out: dict = {}
    tested: dict = {}
    for rec in tests:
        tested.setdefault((rec["scenario"], rec["metric"], rec["filter"]), []).append(rec)
    for label in labels:
        sub = table[table["scenario"] == label]
        per_metric = {}
        for metric in HEADLINE_METRICS:
            per = {}
            for f in filters:
                col = f"{f}.{metric}"
                if col not in sub:
                    continue
                n = int(np.isfinite(sub[col].to_numpy(dtype=float)).sum())
                if not n:
                    continue
                recs = tested.get((label, metric, f), [])
                sig = sorted((r for r in recs if r["significant"]), key=lambda r: (r["p_adjusted"], -abs(r["spearman"])))
                per[f] = {"n": n, "parameters_tested": len(recs),
                          "significant": [{"parameter": r["parameter"], "spearman": round(r["spearman"], 4),
                                           "p": r["p"], "p_adjusted": r["p_adjusted"], "n": r["n"]} for r in sig]}
            if per:
                per_metric[metric] = per
        if per_metric:
            out[label] = per_metric
    return out


def _methods(n_tests: int) -> dict:
    return {
        "percentiles": {
            "value": "numpy.percentile (linear interpolation between order statistics)",
            "ci95": f"percentile bootstrap, scipy.stats.bootstrap, {BOOTSTRAP_RESAMPLES} resamples, "
                    f"seed {_BOOTSTRAP_SEED}",
            "ci95_order_statistic": "distribution-free order-statistic interval, equal tails (Hahn & Meeker 1991, 5.2)",
            "supported": "the order statistics bracket the quantile at 95 % (n_required: the fewest values that do)",
            "confidence_level": CONFIDENCE},
        "drivers": {
            "statistic": "Spearman rank correlation over the units with a finite metric",
            "correction": "Westfall-Young step-down maxT, permutations of the units, one family over every "
                          "scenario, headline metric, filter and parameter (family-wise error rate)",
            "alpha": DRIVER_ALPHA, "permutations": DRIVER_PERMUTATIONS, "seed": _PERMUTATION_SEED,
            "tests": n_tests, "metrics": list(HEADLINE_METRICS)},
    }


def summarize(table, failures: list, labels: list, tests: list | None = None) -> dict:
    """The summary of a sweep's table (one row per finished run) and its failure records.

    ``tests`` are :func:`driver_tests` of ``table`` when the caller has them already (computed otherwise).
    """
    filters = metric_filters(table) if len(table) else []
    params = parameter_names(table) if len(table) else []
    if tests is None:
        tests = driver_tests(table, labels, filters, params) if len(table) and params else []
    out = {"runs": int(len(table)), "failed": len(failures), "methods": _methods(len(tests)),
           "percentiles": _percentiles(table, filters) if len(table) else {}, "by_scenario": {}, "drivers": {}}
    for label in labels:
        sub = table[table["scenario"] == label] if len(table) else table
        out["by_scenario"][label] = {"runs": int(len(sub)),
                                     "failed": sum(1 for r in failures if r.get("scenario") == label),
                                     "percentiles": _percentiles(sub, filters) if len(sub) else {}}
    if len(table) and params:
        out["drivers"] = _drivers(table, labels, filters, params, tests)
    return out
