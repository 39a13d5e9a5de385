"""Allan-deviation figures: log-log deviation per axis with the noise-term slopes marked.

Takes the analyses of :mod:`sins_sim.navigation.allan` (read through their attributes only: this
module imports no physics room). matplotlib is imported lazily (Agg backend).

.. autosummary::

   plot_allan
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.plots.common import _pyplot

__all__ = ["plot_allan", "TERM_STYLE"]

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
    return f"{sym} = {r[k]:.3g} {unit}"


def plot_allan(analyses, path, title: str = "") -> None:
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
    fig, axes = plt.subplots(1, len(items), figsize=(5.2 * len(items), 4.6), squeeze=False, constrained_layout=True)
    for ax, (label, a) in zip(axes[0], items):
        c = a.curve
        scale = a.display_scale
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
            if not term.found or name not in TERM_STYLE:
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
