"""The error-budget bar chart (``sins-sim budget``): each source's share per filter, log scale.

Reads the ``budget.json`` structure of :mod:`sins_sim.jobs.budget` (plain dicts); matplotlib is
imported lazily (Agg backend).
"""

from __future__ import annotations

import numpy as np

from sins_sim.plots.common import _pyplot, filter_color, filter_label, finish_figure

__all__ = ["plot_budget"]


def plot_budget(budget: dict, path=None, title: str = ""):
    """Horizontal bars: rows are the sources (plus total, floor and remainder), one bar per filter.

    Two panels: the final horizontal position error (m) and the final attitude error (arcsec).
    The axis is logarithmic because shares span decades; a share of zero (a source that does not
    touch a filter, e.g. the dither residual of the ideal increments) is drawn as no bar and
    marked "0" at the axis. Returns the Figure: written to ``path`` and closed when given, else left open.
    """
    plt = _pyplot(headless=path is not None)
    filters = [f for f in budget["filters"] if budget["total"].get(f)]
    rows = [("total", budget["total"])] + list(budget["sources"].items()) + [
        ("floor (no source)", budget["floor"]), ("remainder", budget["remainder"])]
    n, m = len(rows), max(1, len(filters))
    height = 0.8 / m
    fig, axes = plt.subplots(1, 2, figsize=(13, 0.42 * n * max(1.0, m / 3) + 1.8), sharey=True,
                             constrained_layout=True)
    for ax, key, unit in ((axes[0], "horizontal_position_error_m", "m"),
                          (axes[1], "attitude_error_arcsec", "arcsec")):
        vals = [[((d.get(f) or {}).get(key) or 0.0) for f in filters] for _, d in rows]
        pos = [v for r in vals for v in r if v and np.isfinite(v) and v > 0]
        # the axis spans at most eight decades below the largest share (smaller ones are rounding)
        lo = max(min(pos) / 3, max(pos) * 1e-8) if pos else 1e-6
        for j, f in enumerate(filters):
            y = np.arange(n) + (j - (m - 1) / 2) * height
            x = np.array([r[j] if r[j] and np.isfinite(r[j]) and r[j] > 0 else np.nan for r in vals])
            x = np.where(x > lo, x, np.nan)
            ax.barh(y, x - lo, left=lo, height=height * 0.95, color=filter_color(f), label=filter_label(f))
        ax.set_xscale("log")
        ax.set_xlim(left=lo)
        ax.set_xlabel("final horizontal position error (m)" if unit == "m" else
                      f"attitude error, mean over the last {budget.get('attitude_window_s', 10.0):.3g} s (arcsec)")
        ax.grid(True, axis="x", which="both", lw=0.3, alpha=0.5)
        for i in range(n):
            ax.axhline(i + 0.5, color="0.85", lw=0.5)
    axes[0].set_yticks(np.arange(n))
    axes[0].set_yticklabels([r for r, _ in rows])
    axes[0].invert_yaxis()
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(4, len(handles)), fontsize=8, frameon=False)
    if title:
        fig.suptitle(title)
    return finish_figure(fig, path, dpi=120)
