"""Figures of an alignment and of a navigation with no truth beside it (a unit's own log).

``alignment_figure``: how each alignment's heading settled over its window, with the 1-sigma it states
(a filter's shrinking sigma, or the final bound drawn at the end), and the tilts. ``displacement_figure``: the
solution's north, east and up displacement from where it started; for a unit that stood still this is its
navigation error.
"""

from __future__ import annotations

import numpy as np

from sins_sim.plots.common import _pyplot, filter_color, finish_figure
from sins_sim.units import ARCSEC

__all__ = ["alignment_figure", "displacement_figure", "METHOD_COLORS"]


#: Colours of the methods where the results are named by method (Okabe & Ito, as the filters').
METHOD_COLORS = {"truth": "#000000", "coarse": "#E69F00", "inertial": "#0072B2", "kalman": "#009E73"}


def _color(name: str) -> str:
    return METHOD_COLORS.get(name) or filter_color(name)


def alignment_figure(results: dict, path=None, title: str = ""):
    """How each :class:`~sins_sim.navigation.alignment_result.AlignmentResult` settled, against its stated sigma.

    ``results``: name -> result (one per filter of a mission, or one per method for a log). Top: how far the
    heading estimated from the data up to t is from the final one (deg, log scale), with the final stated
    1-sigma dashed and, for a filter, its sigma over time dotted: the window was long enough where the curve
    has settled below the dashed line. Bottom: the same for the tilt (the norm of the roll and pitch changes,
    arcsec) against the larger tilt sigma.
    """
    plt = _pyplot(path is not None)
    fig, (ax_h, ax_t) = plt.subplots(2, 1, figsize=(8.0, 6.4), sharex=True, layout="constrained")
    floor_h, floor_t = 1e-6, 1e-3  # deg, arcsec: plotted floor of an exact match (log axes)
    for name, res in results.items():
        hist = res.convergence
        color = _color(name)
        t = np.asarray(hist.get("t_s", np.empty(0)), dtype=float)
        label = name if name == res.method else f"{name} ({res.method})"
        sig_h, sig_t = np.degrees(res.sigma_rad[2]), float(max(res.sigma_rad[0], res.sigma_rad[1])) / ARCSEC
        if t.size:
            head = np.unwrap(np.asarray(hist["heading_rad"], dtype=float))
            ax_h.semilogy(t, np.maximum(np.degrees(np.abs(head - head[-1])), floor_h), color=color, lw=1.4,
                          label=label)
            sig = hist.get("sigma_heading_rad")
            if sig is not None and np.size(sig) == t.size:
                ax_h.semilogy(t, np.degrees(np.asarray(sig, dtype=float)), color=color, lw=1.0, ls=":")
            roll, pitch = (np.asarray(hist[k], dtype=float) for k in ("roll_rad", "pitch_rad"))
            tilt = np.hypot(roll - roll[-1], pitch - pitch[-1]) / ARCSEC
            ax_t.semilogy(t, np.maximum(tilt, floor_t), color=color, lw=1.2, label=label)
        ax_h.axhline(sig_h, color=color, lw=1.0, ls="--")
        ax_t.axhline(sig_t, color=color, lw=1.0, ls="--")
    ax_h.set_ylabel("|heading - final heading| (deg)")
    ax_h.set_title(title or "Alignment: the estimate from the data up to t against the final one; "
                            "dashed: the stated 1-sigma", fontsize=10)
    ax_t.set_ylabel("tilt change to the final (arcsec)")
    ax_t.set_xlabel("time into the alignment window (s)")
    for ax in (ax_h, ax_t):
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8, loc="upper right", ncol=3)
    if any(np.size(r.convergence.get("sigma_heading_rad", ())) for r in results.values()):
        ax_h.text(0.01, 0.03, "dotted: the filter's heading sigma over time", transform=ax_h.transAxes, fontsize=8,
                  color="0.3")
    return finish_figure(fig, path)


def displacement_figure(t_s, displacement_m, path=None, title: str = "", note: str = ""):
    """North, east and up displacement of a solution from its start (m) against time (min), and the
    horizontal distance."""
    plt = _pyplot(path is not None)
    t = np.asarray(t_s, dtype=float)
    d = np.asarray(displacement_m, dtype=float)
    fig, (ax, ax_u) = plt.subplots(2, 1, figsize=(8.0, 6.0), sharex=True, layout="constrained",
                                   gridspec_kw={"height_ratios": [2, 1]})
    span = float(t[-1] - t[0]) if t.size else 0.0
    scale, unit = (60.0, "min") if span >= 300.0 else (1.0, "s")
    minutes = (t - t[0]) / scale if t.size else t
    ax.plot(minutes, d[:, 0], color="#0072B2", lw=1.3, label="north")
    ax.plot(minutes, d[:, 1], color="#D55E00", lw=1.3, label="east")
    ax.plot(minutes, np.hypot(d[:, 0], d[:, 1]), color="#000000", lw=1.5, ls="--", label="horizontal distance")
    ax.set_ylabel("displacement from the start (m)")
    ax.set_title(title or "Free-inertial solution: displacement from where navigation started")
    ax.legend(fontsize=9, loc="best")
    ax_u.plot(minutes, d[:, 2], color="#009E73", lw=1.2, label="up")
    ax_u.set_ylabel("up (m)")
    ax_u.set_xlabel(f"time since navigation started ({unit})")
    ax_u.legend(fontsize=9, loc="best")
    if note:
        ax_u.text(0.01, 0.04, note, transform=ax_u.transAxes, fontsize=8, color="0.3")
    for a in (ax, ax_u):
        a.grid(True, alpha=0.3)
    return finish_figure(fig, path)
