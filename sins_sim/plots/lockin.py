"""Figures of the lock-in study (``sins_sim.jobs.lockin_study``): ARW vs lock-in rate, dynamic lock-in."""

from __future__ import annotations

import numpy as np

from sins_sim.plots.common import _pyplot

__all__ = ["plot_arw_vs_lockin", "plot_dynamic_lockin"]


def plot_arw_vs_lockin(points: list, analytic: dict, path, title: str = "") -> None:
    """Log-log ARW (deg/sqrt(h)) vs lock-in rate (deg/h): measured points and the analytic line.

    ``points``: dicts with ``omega_l_deg_h``, ``arw_increment_deg_rt_h``, ``arw_allan_deg_rt_h``;
    ``analytic``: ``omega_l_deg_h`` and ``arw_deg_rt_h`` arrays and a ``label``.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7.0, 5.0))
    ax.loglog(analytic["omega_l_deg_h"], analytic["arw_deg_rt_h"], "-", color="0.3", label=analytic["label"])
    x = np.array([p["omega_l_deg_h"] for p in points])
    ax.loglog(x, [p["arw_increment_deg_rt_h"] for p in points], "o", color="C0",
              label="simulated: increment variance of the lock-in error")
    ax.loglog(x, [p["arw_allan_deg_rt_h"] for p in points], "s", mfc="none", color="C1",
              label="simulated: Allan deviation, slope -1/2 term")
    from matplotlib.ticker import NullFormatter

    ax.xaxis.set_minor_formatter(NullFormatter())  # decade labels only: the minor labels collide
    ax.set_xlabel("lock-in rate Omega_L (deg/h)")
    ax.set_ylabel("angle random walk (deg/sqrt(h))")
    ax.set_title(title or "Angle random walk of a dithered RLG with random amplitude modulation")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_dynamic_lockin(sweeps: list, path, title: str = "") -> None:
    """Output minus input rate (deg/h) vs input rate (deg/h) around dynamic lock-in zones.

    ``sweeps``: dicts with ``input_deg_h``, ``output_deg_h``, ``zone_center_deg_h``,
    ``half_width_deg_h`` (analytic) and a ``label``; one panel each.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(sweeps), figsize=(5.5 * len(sweeps), 4.5), squeeze=False)
    for ax, sw in zip(axes[0], sweeps):
        x = np.asarray(sw["input_deg_h"])
        y = np.asarray(sw["output_deg_h"])
        c, w = sw["zone_center_deg_h"], sw["half_width_deg_h"]
        ax.axvspan(c - w, c + w, color="C2", alpha=0.2, label="analytic zone: |Omega - n f_D fringe| <= Omega_L |J_n(K a)|")
        ax.plot(x, y - x, "o-", ms=3, color="C0", label="simulated output - input")
        ax.plot(x, c - x, ":", color="0.4", label="output stuck at n f_D fringe")
        ax.set_xlabel("input rate (deg/h)")
        ax.set_ylabel("output rate - input rate (deg/h)")
        ax.set_title(sw["label"], fontsize=9)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="lower left")
    fig.suptitle(title or "Dynamic lock-in, constant dither amplitude (modulation depth 0)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
