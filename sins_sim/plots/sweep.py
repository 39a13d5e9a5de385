"""Figures of a Monte Carlo sweep (``sins-sim sweep``): metric distributions and what drives them.

* :func:`plot_distributions`: per scenario (rows) and headline metric (columns), the empirical
  cumulative distribution of each filter's metric over the units, on a log axis (the filters differ
  by decades), with the 95th percentile marked.
* :func:`plot_sensitivity`: one metric against each drawn parameter, per filter; a panel's title names
  the rank correlation and its adjusted p-value only where the sweep's driver test finds the parameter
  significant (:mod:`sins_sim.jobs.sweep.summary`), otherwise ``n.s. (n=...)``.
"""

from __future__ import annotations

import math
import textwrap

import numpy as np

from sins_sim.plots.common import FILTER_LABELS, _pyplot, filter_color, finish_figure

__all__ = ["plot_distributions", "plot_sensitivity"]

_LABELS = {**FILTER_LABELS, "ideal": "ideal increments"}


def _positive(x):
    x = np.asarray(x, dtype=float)
    return x[np.isfinite(x) & (x > 0.0)]


def plot_distributions(table, metrics: dict, filters, scenarios, path=None, title: str = "", p95_min_n: int = 1):
    """ECDF of each metric per filter; ``metrics`` maps a metric column suffix to its axis label (units).

    The 95th percentile is marked where a filter has at least ``p95_min_n`` values (the sample size that
    supports it). Returns the Figure (written to ``path`` and closed when given, else left open), or None
    (and writes nothing) when no metric has a positive finite value.
    """
    panels = []
    for sc in scenarios:
        sub = table[table["scenario"] == sc]
        for metric, label in metrics.items():
            if any(_positive(sub.get(f"{f}.{metric}", [])).size for f in filters):
                panels.append((sc, metric, label, sub))
    if not panels:
        return None
    cols = len({m for _, m, _, _ in panels})
    metric_cols = [m for m in metrics if any(m == pm for _, pm, _, _ in panels)]
    rows = [sc for sc in scenarios if any(sc == ps for ps, _, _, _ in panels)]
    plt = _pyplot(headless=path is not None)
    fig, axes = plt.subplots(len(rows), cols, figsize=(4.6 * cols, 3.6 * len(rows)), squeeze=False,
                             constrained_layout=True)
    for ax in axes.flat:
        ax.set_visible(False)
    handles = {}
    for sc, metric, label, sub in panels:
        ax = axes[rows.index(sc), metric_cols.index(metric)]
        ax.set_visible(True)
        values = np.concatenate([_positive(sub[f"{f}.{metric}"]) for f in filters if f"{f}.{metric}" in sub])
        log = values.max() > 20.0 * values.min()  # a log axis only where the filters differ by decades
        for f in filters:
            col = f"{f}.{metric}"
            if col not in sub:
                continue
            x = np.sort(_positive(sub[col]))
            if not x.size:
                continue
            p = np.arange(1, x.size + 1) / x.size
            (h,) = ax.step(x, p, where="post", color=filter_color(f), lw=1.4, label=_LABELS.get(f, f))
            if x.size >= p95_min_n:
                p95 = float(np.percentile(x, 95.0))
                ax.plot([p95], [0.95], "o", color=filter_color(f), ms=4)
            handles[f] = h
        if log:
            ax.set_xscale("log")
            ax.xaxis.set_minor_formatter(plt.NullFormatter())
        else:
            ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, 4))
            ax.tick_params(axis="x", labelsize=8)
        ax.set_ylim(0.0, 1.02)
        ax.axhline(0.95, color="0.5", lw=0.6, ls=":")
        ax.set_xlabel(label)
        ax.set_ylabel("fraction of units")
        ax.set_title(f"{sc}: {metric}", fontsize=9)
        ax.grid(True, which="major", alpha=0.3)
    fig.legend(list(handles.values()), [_LABELS.get(f, f) for f in handles], loc="outside lower center",
               ncol=min(len(handles), 5), fontsize=8)
    dots = "dots: 95th percentile" + (f", where n >= {p95_min_n}" if p95_min_n > 1 else "")
    fig.suptitle(f"{title or 'distribution over the units'} ({dots})")
    return finish_figure(fig, path)


def _driver_title(tests: list) -> str:
    """The second line of a sensitivity panel's title from the driver tests of its parameter (one per filter)."""
    if not tests:
        return "not tested"
    sig = sorted((t for t in tests if t.get("significant")), key=lambda t: (t["p_adjusted"], -abs(t["spearman"])))
    if not sig:
        return f"n.s. (n={max(t['n'] for t in tests)})"
    t = sig[0]
    floor = t.get("p_resolution", 0.0)
    p = f"p_adj <= {floor:.1g}" if t["p_adjusted"] <= floor else f"p_adj {t['p_adjusted']:.1g}"
    more = f"; +{len(sig) - 1} filter(s)" if len(sig) > 1 else ""
    return f"{_LABELS.get(t['filter'], t['filter'])}: rho {t['spearman']:+.2f}, {p}, n={t['n']}{more}"


def plot_sensitivity(table, metric: str, label: str, params: dict, filters, path, title: str = "",
                     tests: dict | None = None) -> bool:
    """``metric`` against each drawn parameter (``params``: column -> axis label), one point per unit and filter.

    ``tests`` maps (parameter column, filter) to the driver test of that pair (``spearman``, ``n``,
    ``p_adjusted``, ``significant`` and optionally ``p_resolution``, the smallest p-value the test can give):
    a panel's title gives rho and the adjusted p-value of its most significant filter, or ``n.s. (n=...)``.
    Returns False when the metric has no positive finite value.
    """
    # a filter whose metric does not vary over the units (ideal increments) has nothing to show here
    cols_y = [f for f in filters if f"{f}.{metric}" in table and np.unique(_positive(table[f"{f}.{metric}"])).size > 1]
    if not cols_y or not params:
        return False
    y_all = np.concatenate([_positive(table[f"{f}.{metric}"]) for f in cols_y])
    span = float(y_all.max() / y_all.min())
    n = len(params)
    ncols = min(n, 4)
    nrows = math.ceil(n / ncols)
    plt = _pyplot()
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 3.2 * nrows + 0.5), squeeze=False,
                             constrained_layout=True, sharey=True)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    handles = {}
    for ax, (pcol, plabel) in zip(axes.flat, params.items()):
        x = table[pcol].to_numpy(dtype=float)
        for f in cols_y:
            y = table[f"{f}.{metric}"].to_numpy(dtype=float)
            ok = np.isfinite(x) & np.isfinite(y) & (y > 0.0)
            handles[f] = ax.scatter(x[ok], y[ok], s=9, color=filter_color(f), alpha=0.7, lw=0,
                                    label=_LABELS.get(f, f))
        found = [t for (pc, f), t in (tests or {}).items() if pc == pcol]
        ax.set_yscale("log")
        if span > 10.0:  # under a decade the minor ticks carry the only labels
            ax.yaxis.set_minor_formatter(plt.NullFormatter())
        ax.set_xlabel(textwrap.fill(plabel, 44), fontsize=8)  # long parameter names: two lines, not into the next panel
        ax.set_title(f"{pcol.split('.', 1)[1]}\n{_driver_title(found)}", fontsize=8)
        ax.grid(True, which="both", alpha=0.25)
        ax.tick_params(labelsize=7)
    fig.supylabel(label, fontsize=9)  # one label for the shared axis (a long one per row overlaps the next row)
    fig.legend(list(handles.values()), [_LABELS.get(f, f) for f in handles], loc="outside lower center",
               ncol=min(len(handles), 5), fontsize=8)
    fig.suptitle(title or f"{metric} against each drawn parameter (rho: Spearman rank correlation)", fontsize=10)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return True
