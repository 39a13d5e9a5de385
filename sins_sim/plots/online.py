"""The online estimator's estimates against the unit's truth over a run (issue 29)."""

from __future__ import annotations

import numpy as np

from sins_sim.plots.common import _pyplot, finish_figure

__all__ = ["plot_online_estimates"]

_PANELS = (("f0_hz", "f0", 1e6, "ppm"), ("k1", "k1", 100.0, "%"), ("k2", "k2", 100.0, "%"),
           ("q", "Q", 100.0, "%"), ("k3", "k3", 100.0, "%"), ("k5", "k5", 100.0, "%"))
#: One colour per axis (Okabe & Ito, as the filters' palette).
_AXIS_COLORS = {"x": "#0072B2", "y": "#D55E00", "z": "#009E73"}


def plot_online_estimates(histories: dict, path) -> None:
    """Relative error of each estimate against the unit's truth at each update, per axis.

    Parameters
    ----------
    histories : dict axis -> dict
        :func:`sins_sim.simulation.online.history_arrays` of each axis.
    path : path
        The PNG to write.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(3, 2, figsize=(10, 8), sharex=True)
    for ax, (key, label, scale, unit) in zip(axes.ravel(), _PANELS):
        for axis, h in histories.items():
            err = (h[f"estimate_{key}"] / h[f"truth_{key}"] - 1.0) * scale
            ax.plot(h["t_s"], err, color=_AXIS_COLORS.get(axis), lw=1.0, label=f"axis {axis}")
            sd = h.get(f"std_{key}")
            if sd is not None and np.any(np.isfinite(sd)):
                band = sd / h[f"truth_{key}"] * scale
                ax.fill_between(h["t_s"], err - band, err + band, color=_AXIS_COLORS.get(axis), alpha=0.15, lw=0)
        ax.axhline(0.0, color="black", lw=0.6)
        ax.set_ylabel(f"{label}: estimate / truth - 1 ({unit})")
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Online estimates against the unit's truth (band: the estimator's stated 1 sigma)")
    finish_figure(fig, path)
