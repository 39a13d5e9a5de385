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

__all__ = ["alignment_figure", "displacement_figure"]


def alignment_figure(results: dict, path=None, title: str = ""):
    """Heading and tilt histories of each :class:`~sins_sim.navigation.alignment_result.AlignmentResult`.

    ``results``: name -> result (one per filter of a mission, or one for a log). The heading is drawn relative
    to its final value (deg), so that several alignments of one unit share an axis; the band is the stated
    1-sigma where the method keeps its history, else an error bar at the end.
    """
    plt = _pyplot(path is not None)
    fig, (ax_h, ax_t) = plt.subplots(2, 1, figsize=(8.0, 6.2), sharex=True, layout="constrained")
    for name, res in results.items():
        hist = res.convergence
        color = filter_color(name)
        t = np.asarray(hist.get("t_s", np.empty(0)), dtype=float)
        if t.size:
            head = np.unwrap(np.asarray(hist["heading_rad"], dtype=float))
            ax_h.plot(t, np.degrees(head - head[-1]), color=color, lw=1.3, label=f"{name} ({res.method})")
            sig = hist.get("sigma_heading_rad")
            if sig is not None and np.size(sig) == t.size:
                s = np.degrees(np.asarray(sig, dtype=float))
                ax_h.fill_between(t, -s, s, color=color, alpha=0.12, lw=0)
            for key, style in (("roll_rad", "-"), ("pitch_rad", "--")):
                x = np.asarray(hist[key], dtype=float)
                ax_t.plot(t, (x - x[-1]) / ARCSEC, color=color, lw=1.1, ls=style,
                          label=f"{name}: {key.split('_')[0]}")
        end = float(res.duration_s)
        ax_h.errorbar([end], [0.0], yerr=[np.degrees(res.sigma_rad[2])], color=color, capsize=4, lw=1.5, fmt="o",
                      ms=3)
        ax_t.errorbar([end, end], [0.0, 0.0], yerr=[res.sigma_rad[0] / ARCSEC, res.sigma_rad[1] / ARCSEC],
                      color=color, capsize=4, lw=1.0, fmt="none")
    ax_h.axhline(0.0, color="0.6", lw=0.8)
    ax_h.set_ylabel("heading minus its final value (deg)")
    ax_h.set_title(title or "Alignment: the estimate from the data up to t; bars: the stated 1-sigma at the end")
    ax_t.axhline(0.0, color="0.6", lw=0.8)
    ax_t.set_ylabel("roll, pitch minus final (arcsec)")
    ax_t.set_xlabel("time into the alignment window (s)")
    for ax in (ax_h, ax_t):
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8, loc="best", ncol=2)
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
