"""Figures of the block on its isolators (``sins_sim.jobs.separation_study``)."""

from __future__ import annotations

import numpy as np

from sins_sim.plots.common import _pyplot, filter_color, filter_label, finish_figure, line_style

__all__ = ["plot_separation_study"]


def plot_separation_study(res: dict, path=None):
    """The beat the dither coning puts into each filter's error about the third axis (measured where the stored
    series resolves it) beside its closed form and the budget, and the cross-axis ratio beside the entrainment
    criterion, against the separation of the two drive frequencies (log axes: the beat grows as 1 / separation)."""
    plt = _pyplot(headless=path is not None)
    pts = sorted(res["points"], key=lambda p: p["separation_hz"])
    x = np.array([p["separation_hz"] for p in pts])
    a, b = res["settings"]["pair"]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7.5, 7.0), sharex=True)
    names = list(pts[0]["heading_error"])
    for name in names:
        y = np.array([np.nan if p["heading_error"][name]["beat_arcsec"] is None else p["heading_error"][name]["beat_arcsec"]
                      for p in pts])
        ok = np.isfinite(y) & (y > 0)
        if not ok.any():
            continue
        ax1.loglog(x[ok], y[ok], marker="o", label=filter_label(name), ms=4, **line_style(name))
    beat = np.array([p["coning_beat_closed_form_arcsec"] for p in pts])
    ax1.loglog(x, beat, ":", color="0.2", lw=1.6, label="closed form a_x a_y (w_x + w_y) / (4 |w_x - w_y|)")
    ax1.axhline(res["settings"]["budget_arcsec"], color="0.3", ls="--", lw=1,
                label=f"budget ({res['settings']['budget_arcsec']:g} arcsec)")
    c = "xyz"[3 - "xyz".index(a) - "xyz".index(b)]
    ax1.set_ylabel(f"beat in the error about {c} (arcsec)")
    ax1.set_title(f"Dither coning on one block: axis {b}'s drive brought to axis {a}'s", fontsize=10)
    ax1.grid(True, which="both", alpha=0.3)
    lo, hi = ax1.get_ylim()
    ax1.set_ylim(lo, hi * 100.0)  # headroom above the data for the legend
    ax1.legend(fontsize=7.5, loc="upper right", ncol=2)
    ratio = np.array([p["cross_axis_ratio"] for p in pts])
    ax2.loglog(x, ratio, "s-", color=filter_color("raw"), ms=4, label=f"gyro {b}: line at {a}'s drive / own dither")
    ax2.axhline(res["settings"]["lock_ratio"], color="0.3", ls="--", lw=1,
                label=f"entrainment-risk criterion ({res['settings']['lock_ratio']:g})")
    ax2.set_xlabel("separation of the two drive frequencies (Hz)")
    ax2.set_ylabel("cross-axis / own dither")
    ax2.grid(True, which="both", alpha=0.3)
    ax2.legend(fontsize=7.5)
    fig.tight_layout()
    return finish_figure(fig, path)
