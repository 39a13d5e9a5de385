"""Figures of ``sins-sim compare-filters``: end-to-end gain per filter, noise against flat bandwidth."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sins_sim.plots.common import _pyplot, filter_color, filter_label

__all__ = ["plot_gain", "plot_tradeoff"]

_label = filter_label
_color = filter_color


def plot_gain(gain: dict, path, top_db: float = 2.0, bottom_db: float = -6.0) -> str:
    """Measured end-to-end gain (markers, worst axis) beside the analytic linear curve (lines), in dB.

    Two panels: the whole range to Nyquist, and a zoom on +-1 dB with the 1 % and 5 % target bands.
    """
    plt = _pyplot()
    f = np.asarray(gain["freqs"])
    fig, axes = plt.subplots(1, 2, figsize=(14, 6.2), layout="constrained")
    for ax, (lo, hi) in zip(axes, ((bottom_db, top_db), (-1.0, 1.0))):
        for n, g in gain["measured"].items():
            g = np.asarray(g)
            worst = g[np.argmax(np.abs(g - 1.0), axis=0), np.arange(g.shape[1])]
            c = _color(n)
            ax.plot(f, 20.0 * np.log10(np.maximum(worst, 1e-6)), "o", ms=4, color=c, label=f"{_label(n)}: measured")
            if n in gain["analytic"]:
                ax.plot(gain["analytic_f"], 20.0 * np.log10(np.maximum(gain["analytic"][n], 1e-6)), "-", lw=1.0,
                        color=c, alpha=0.8)
        for fd in gain["dithers"]:
            ax.axvline(fd, color="0.8", lw=0.8, ls=":")
        # the targets in grey: the filters' colours stay theirs alone
        ax.axhspan(20 * np.log10(0.99), 20 * np.log10(1.01), color="0.55", alpha=0.18, lw=0, zorder=0)
        ax.axhspan(20 * np.log10(0.95), 20 * np.log10(1.05), color="0.55", alpha=0.08, lw=0, zorder=0)
        ax.axvline(1500.0, color="0.3", lw=0.8, ls="--", zorder=0)
        ax.axvline(2500.0, color="0.3", lw=0.8, ls="--", zorder=0)
        ax.set_xscale("log")
        ax.set_ylim(lo, hi)
        ax.set_xlim(70.0, f.max() * 1.02)
        ax.set_xlabel("frequency of the 1 arcmin block sine (Hz)")
        ax.set_ylabel("end-to-end gain, SINS angle to filter output (dB)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_title("gain to Nyquist: markers measured (nonlinear plant, dither on), lines analytic (linear)")
    axes[1].set_title("zoom: shaded 1 % and 5 % targets; dashed 1.5 and 2.5 kHz; dotted: dithers")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=8, frameon=False)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path).name


def plot_tradeoff(trade: dict, filters: dict, path, q_key: str) -> str:
    """Quantisation noise (q = ``q_key`` arcsec, white-noise model) against the band flat to 1 %."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(9, 6))
    for k, (name, pts) in enumerate(trade["curves"].items()):
        pts = np.asarray(pts)
        # designs that reach their own pass edge (shorter equalisers fail at wide pass bands: left out)
        ok = pts[:, 1] >= pts[:, 0] - 150.0
        # design curves in Tol's colour-blind-safe indigo, wine, teal: none of them a filter's colour
        ax.plot(pts[ok, 1], pts[ok, 2], "-", marker=".", color=("#332288", "#882255", "#44AA99")[k % 3],
                label=f"equalised second difference, {name} (delay {name[2:]} samples), stop edge = pass + 600 Hz")
    ax.plot(trade["bound_f_hz"], trade["bound_arcsec"], "k--", lw=1.2,
            label="bound: exact inversion to the band, nothing above it")
    for n, (fb, noise) in trade["points"].items():
        if n == "correcting":  # open and larger: the aligned form sits on the same point
            ax.plot(fb, noise, "s", ms=15, mfc="none", mew=2, color=_color(n), label=f"{_label(n)}")
        else:
            ax.plot(fb, noise, "s", ms=9, color=_color(n), label=f"{_label(n)}")
    ax.set_xlabel("band flat to 1 % from 80 Hz (Hz, analytic linear cascade)")
    ax.set_ylabel(f"quantisation noise at the output, q = {q_key} arcsec (arcsec RMS)")
    ax.set_title("noise against flat bandwidth: pick a point on a curve")
    ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path).name
