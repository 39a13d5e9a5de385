"""Allan-deviation figures: log-log deviation per axis with the noise-term slopes marked.

Takes the analyses of :mod:`sins_sim.navigation.allan` (read through their attributes only: this
module imports no physics room). matplotlib is imported lazily (Agg backend).

.. autosummary::

   plot_allan
   plot_allan_filters
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.plots.common import _pyplot, filter_color, filter_label, finish_figure

__all__ = ["plot_allan", "plot_allan_filters", "has_curves", "TERM_STYLE"]

#: name -> (label for a gyro, label for an accelerometer, colour, the tau (s) at which the reading is taken)
TERM_STYLE = {
    "quantization": ("quantisation, slope -1", "quantisation, slope -1", "tab:purple", None),
    "white": ("angle random walk, slope -1/2 (N at 1 s)", "velocity random walk, slope -1/2 (N at 1 s)",
              "tab:blue", 1.0),
    "flicker": ("bias instability, slope 0 (floor 0.664 B)", "bias instability, slope 0 (floor 0.664 B)",
                "tab:green", None),
    "random_walk": ("rate random walk, slope +1/2 (K at 3 s)", "acceleration random walk, slope +1/2 (K at 3 s)",
                    "tab:red", 3.0),
    "ramp": ("rate ramp, slope +1", "ramp, slope +1", "tab:orange", None),
}


def _finite(x) -> bool:
    return x is not None and np.isfinite(x)


def _reading_key(sensor: str, name: str):
    if sensor == "gyro":
        return {"quantization": "quantization_arcsec", "white": "arw_deg_rt_h", "flicker": "bias_instability_deg_h",
                "random_walk": "rrw_deg_h_rt_h"}.get(name)
    return {"quantization": "quantization_m_s", "white": "vrw_ug_rt_hz", "flicker": "bias_instability_ug",
            "random_walk": "rrw_ug_rt_h"}.get(name)


def _determined(analysis, name) -> bool:
    """A term is drawn only when it was found and its reading is determined (not null) in the results."""
    term = analysis.terms.get(name)
    if term is None or not term.found:
        return False
    key = _reading_key(analysis.sensor, name)
    return key is None or _finite(analysis.readings().get(key))


def _drawable(a):
    """The points of analysis ``a`` that are drawn: enough clusters and a positive finite deviation (log axes)."""
    c = a.curve
    return (c.clusters >= a.min_clusters) & np.isfinite(c.adev) & (c.adev > 0.0)


def has_curves(by_filter: dict) -> bool:
    """Whether :func:`plot_allan_filters` has a point to draw (e.g. not for an error that is zero throughout)."""
    return any(np.count_nonzero(_drawable(a)) >= 2 for per_axis in by_filter.values()
               for a in per_axis.values() if a is not None)


def _reading_text(analysis, name) -> str:
    r = analysis.readings()
    if analysis.sensor == "gyro":
        key = {"quantization": ("quantization_arcsec", "Q", "arcsec"), "white": ("arw_deg_rt_h", "N", "deg/sqrt(h)"),
               "flicker": ("bias_instability_deg_h", "B", "deg/h"), "random_walk": ("rrw_deg_h_rt_h", "K", "deg/h/sqrt(h)")}
    else:
        key = {"quantization": ("quantization_m_s", "Q", "m/s"), "white": ("vrw_ug_rt_hz", "N", "ug/sqrt(Hz)"),
               "flicker": ("bias_instability_ug", "B", "ug"), "random_walk": ("rrw_ug_rt_h", "K", "ug/sqrt(h)")}
    if name not in key:
        return ""
    k, sym, unit = key[name]
    return f"{sym} = {r[k]:.3g} {unit}" if _finite(r.get(k)) else ""


def plot_allan(analyses, path, title: str = "", ncols: int | None = None) -> None:
    """Log-log Allan deviation of each axis with the fitted slope lines, their regions and readings.

    Parameters
    ----------
    analyses : AllanAnalysis or dict
        One analysis or ``{label: AllanAnalysis}`` (e.g. the axes ``x``, ``y``, ``z`` from
        :func:`sins_sim.navigation.allan.allan_axes`); one panel each, side by side.
    path : path
        The image file to write (format from the suffix).
    title : str
        Figure title.
    ncols : int, optional
        Panels per row (default: all in one row); e.g. 3 for a gyro row over an accelerometer row.

    Notes
    -----
    Each panel shows the measured overlapping Allan deviation with its 1-sigma band (points averaged
    over fewer than the analysis' ``min_clusters`` clusters in grey: not used by the fit), the
    fitted power-law sum (thin black), and every term found as a line of its slope: solid over the
    tau range it was read from, dashed elsewhere, with a marker where the reading is taken (N at
    tau = 1 s, K at tau = 3 s, the floor 0.664 B over its range). The deviation is in deg/h for
    gyros and ug for accelerometers, tau in s.
    """
    plt = _pyplot()
    items = list(analyses.items()) if isinstance(analyses, dict) else [("", analyses)]
    if not items:
        raise ValueError("plot_allan.analyses: nothing to plot")
    cols = len(items) if ncols is None else max(1, min(int(ncols), len(items)))
    rows = -(-len(items) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 4.6 * rows), squeeze=False, constrained_layout=True)
    for ax in axes.flat[len(items):]:
        ax.set_visible(False)
    for ax, (label, a) in zip(axes.flat, items):
        c = a.curve
        scale = a.display_scale
        if not np.any(c.adev > 0.0):  # a channel constant at its pulse weight: nothing on a log scale
            ax.set_title(label)
            ax.text(0.5, 0.5, "no Allan deviation:\nthe channel shows no noise\nabove its pulse weight",
                    ha="center", va="center", transform=ax.transAxes)
            ax.set_xticks([])
            ax.set_yticks([])
            continue
        used = c.clusters >= a.min_clusters
        ax.fill_between(c.tau_s, (c.adev - c.adev_err) * scale, (c.adev + c.adev_err) * scale,
                        color="0.85", lw=0, label="1-sigma of the estimate")
        ax.loglog(c.tau_s[used], c.adev[used] * scale, "o", ms=3, color="k", label="overlapping ADEV")
        if np.any(~used):
            ax.loglog(c.tau_s[~used], c.adev[~used] * scale, "o", ms=3, color="0.6",
                      label=f"< {a.min_clusters:g} clusters (not fitted)")
        tau = np.geomspace(c.tau_s[0], c.tau_s[-1], 200)
        if any(v > 0.0 for v in a.coefficients.values()):
            ax.loglog(tau, a.model_adev(tau) * scale, color="k", lw=0.7, alpha=0.6, label="fitted power-law sum")
        for name, term in a.terms.items():
            if name not in TERM_STYLE or not _determined(a, name):
                continue
            gyro_text, accel_text, color, at = TERM_STYLE[name]
            text = gyro_text if a.sensor == "gyro" else accel_text
            ax.loglog(tau, a.line(name, tau) * scale, color=color, lw=1.0, ls="--", alpha=0.7)
            lo, hi = term.tau_range_s
            seg = np.geomspace(lo, hi, 50) if hi > lo else np.array([lo])
            reading = _reading_text(a, name)
            ax.loglog(seg, a.line(name, seg) * scale, color=color, lw=2.4,
                      label=f"{text}: {reading} ({lo:.3g}-{hi:.3g} s)" if reading else text)
            if at is not None:
                ax.loglog([at], a.line(name, np.array([at])) * scale, "s", color=color, ms=6, mfc="none")
        ax.set_xlabel("averaging time tau (s)")
        ax.set_ylabel(f"Allan deviation ({a.display_unit})")
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        dur = c.duration_s
        ax.set_title(f"{label + ': ' if label else ''}{a.sensor}, {c.rate_hz:g} Hz, "
                     f"{dur:.4g} s record" if math.isfinite(dur) else label)
        ax.legend(fontsize=7, loc="best")
    if title:
        fig.suptitle(title)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_allan_filters(by_filter: dict, path=None, title: str = "", colors: dict | None = None,
                       labels: dict | None = None):
    """The gyro Allan deviation of every filter's output error, one panel per axis, curves overlaid.

    Parameters
    ----------
    by_filter : dict
        ``{filter: {"x": AllanAnalysis, "y": ..., "z": ...}}`` (gyro analyses).
    path : path, optional
        The image file to write (the figure is then closed); None: the figure is left open.
    title : str
        Figure title.
    colors, labels : dict, optional
        Per filter name (default: the shared map of :mod:`sins_sim.plots.common`).

    Returns
    -------
    matplotlib.figure.Figure

    Notes
    -----
    Only the points averaged over at least ``min_clusters`` clusters are drawn. A slope -1/2 guide
    through the ideal output's angle-random-walk reading (where found) shows the sensor's ARW; the
    filters that sit above it at short tau show their own noise (slope -1: the readout quantum
    amplified by the filter) before they meet it.
    """
    plt = _pyplot(headless=path is not None)
    colors, labels = colors or {}, labels or {}
    color_of = lambda n: colors.get(n) or filter_color(n)  # noqa: E731
    label_of = lambda n: labels.get(n) or filter_label(n)  # noqa: E731
    axes_names = ("x", "y", "z")
    fig, axs = plt.subplots(1, 3, figsize=(15, 4.8), sharey=True, constrained_layout=True)
    for ax, axis in zip(axs, axes_names):
        for name, per_axis in by_filter.items():
            a = per_axis.get(axis)
            if a is None:
                continue
            c = a.curve
            used = _drawable(a)
            if not np.any(used):
                continue
            r = a.readings()
            arw = r.get("arw_deg_rt_h")
            extra = f", ARW {arw:.3g} deg/sqrt(h)" if arw is not None and np.isfinite(arw) else ""
            ax.loglog(c.tau_s[used], c.adev[used] * a.display_scale, "o-", ms=3, lw=1.0, color=color_of(name),
                      label=f"{label_of(name)}{extra}", zorder=5 if name == "ideal" else 3)
        ideal = by_filter.get("ideal", {}).get(axis)
        if ideal is not None and _determined(ideal, "white"):
            tau = np.geomspace(ideal.curve.tau_s[0], ideal.curve.tau_s[-1], 50)
            ax.loglog(tau, ideal.line("white", tau) * ideal.display_scale, "--", color="0.45", lw=0.9,
                      label="sensor ARW line (slope -1/2)")
        ax.set_xlabel("averaging time tau (s)")
        ax.set_title(f"gyro {axis}: output error (output - truth)")
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.legend(fontsize=7, loc="best")
    axs[0].set_ylabel("Allan deviation (deg/h)")
    if title:
        fig.suptitle(title)
    return finish_figure(fig, path, dpi=120)
