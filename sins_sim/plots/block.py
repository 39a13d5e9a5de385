"""Figures of the block on its isolators: its motion spectrum in a run (``block_spectrum.png``) and the
resonance-separation study (``sins_sim.jobs.separation_study``)."""

from __future__ import annotations

import numpy as np

from sins_sim.earth import level_body_from_ned
from sins_sim.plots.common import _pyplot, filter_color, filter_label, finish_figure, line_style
from sins_sim.units import ARCSEC

__all__ = ["plot_separation_study", "plot_block_spectrum", "block_spectrum_segment", "plot_block_coning"]

#: Welch segment of the block's motion spectrum (s): 1 Hz bins separate the dither lines (30-70 Hz apart) and
#: resolve the isolator modes (half-power bandwidth 2 zeta f = 8-10 Hz at 5 % damping).
BLOCK_SEGMENT_S = 1.0


def block_spectrum_segment(n: int, fs: float) -> int:
    """Welch segment length (samples) for a block record of ``n`` samples at ``fs``: :data:`BLOCK_SEGMENT_S`, or half
    the record when it is shorter than two segments (at least three half-overlapping segments to average)."""
    return max(64, min(int(round(BLOCK_SEGMENT_S * fs)), n // 2))


def plot_block_spectrum(res, path=None, title: str = ""):
    """Amplitude spectral density of the block's own rotation relative to the chassis, about each block axis
    (arcsec/sqrt(Hz)), with each gyro's drive frequency and the isolator modes marked.

    ``res.block`` (``SinsResult.block``): Welch's method (4-term Blackman-Harris window, 50 % overlap, linear
    detrend, one-sided density). The window's sidelobes (-92 dB, Harris 1978) keep the 3 arcsec dither lines from
    hiding the isolator modes 300 Hz below them, as a Hann window's skirt would. A dither line of amplitude ``A``
    shows as a peak of ``A / sqrt(2 ENBW)`` (ENBW = 2.0 / segment for this window); the run's ``metrics.json``
    (``block.dither_lines``) gives the lines' amplitudes.
    """
    from scipy import signal

    rec = res.block
    if rec is None or rec["theta_rad"].shape[0] < 128:
        raise ValueError("plot_block_spectrum: no block record to analyse (an IMU without block:, or too short)")
    plt = _pyplot(headless=path is not None)
    fs = float(rec["rate_hz"])
    theta = rec["theta_rad"] / ARCSEC
    nper = block_spectrum_segment(theta.shape[0], fs)
    f, p = signal.welch(theta, fs=fs, window="blackmanharris", nperseg=nper, noverlap=nper // 2, axis=0,
                        detrend="linear")
    fig, axes = plt.subplots(3, 1, figsize=(10, 9.5), sharex=True, layout="constrained")
    colors = ("C0", "C1", "C2")
    drives = [d["frequency_hz"] for d in res.drives]
    for i, ax in enumerate(axes):
        y = np.sqrt(p[1:, i])
        ok = y > 0
        ax.loglog(f[1:][ok], y[ok], color=colors[i], lw=1.0)
        for j, fd in enumerate(drives):
            ax.axvline(fd, color=colors[j], ls="--", lw=0.9, alpha=0.8, zorder=0,
                       label=f"gyro {'xyz'[j]} drive {fd:.2f} Hz")
        for k, fm in enumerate(rec["isolator_modes_hz"]):
            ax.axvline(fm, color="0.45", ls=":", lw=1.0, zorder=0, label="isolator modes" if k == 0 else "_")
        ax.set_ylabel(f"about block {'xyz'[i]}\n(arcsec/sqrt(Hz))")
        ax.grid(True, which="major", alpha=0.3)
    axes[-1].set_xlabel("frequency (Hz)")
    axes[-1].set_xlim(max(1.0, 2.0 * fs / nper), fs / 2.0)
    t = rec["t_s"]
    axes[0].set_title(f"{title}\n(Welch: Blackman-Harris window of {nper} samples = {nper / fs:.3g} s, 50% overlap, linear "
                      f"detrend; record t = {t[0]:.4g}-{t[-1] + 1.0 / fs:.4g} s at {fs:g} Hz)", fontsize=10)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=8, frameon=False)
    return finish_figure(fig, path)


def plot_separation_study(res: dict, path=None):
    """The beat the dither coning puts into each filter's error about the third axis (measured where the stored
    series resolves it) beside its closed form and the budget, and the cross-axis ratio beside the entrainment
    criterion, and the live PLLs' pull of the first drive (measured, from the linear coupled modes, and the
    weak-coupling closed form) with each drive's frequency modulation at the beat, against the separation of the two
    drive frequencies (log axes: the beat and the pull grow as 1 / separation)."""
    plt = _pyplot(headless=path is not None)
    pts = sorted(res["points"], key=lambda p: p["separation_hz"])
    x = np.array([p["separation_hz"] for p in pts])
    a, b = res["settings"]["pair"]
    fig, (ax1, ax2, ax3) = plt.subplots(3, 1, figsize=(7.5, 10.0), sharex=True)
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
    ax2.set_ylabel("cross-axis / own dither")
    ax2.grid(True, which="both", alpha=0.3)
    ax2.legend(fontsize=7.5)
    for key, style, label in (("pull_hz", "o-", f"{a}'s drive on its PLL, measured"),
                              ("pull_linear_modes_hz", "s--", "linear coupled modes"),
                              ("pull_closed_form_hz", ":", "weak coupling: kappa^2 f^3 / (2 (f_a^2 - f_b^2))")):
        y = np.array([abs(p["pll"][key]) for p in pts])
        ok = y > 0
        if ok.any():
            ax3.loglog(x[ok], y[ok], style, ms=4, label=f"|pull| ({label})")
    for axis, style in ((a, "^-"), (b, "v-")):
        y = np.array([np.nan if p["pll"]["fm_at_beat_hz"][axis] is None else p["pll"]["fm_at_beat_hz"][axis]
                      for p in pts])
        ok = np.isfinite(y) & (y > 0)
        if ok.any():
            ax3.loglog(x[ok], y[ok], style, ms=4, alpha=0.7, label=f"{axis}'s frequency modulation at the beat")
    ax3.set_xlabel("separation of the two drive frequencies (Hz)")
    ax3.set_ylabel("frequency (Hz)")
    ax3.set_title(f"Live PLLs ({res['settings']['pll']['bandwidth_hz']:g} Hz): pull and modulation", fontsize=10)
    ax3.grid(True, which="both", alpha=0.3)
    ax3.legend(fontsize=7.5)
    fig.tight_layout()
    return finish_figure(fig, path)


def plot_block_coning(res, coning: list, path=None, title: str = ""):
    """Each filter's attitude error about the coning axis of each slowly beating pair of dithers, against time
    (the stored means over each interval: the dither lines average out, the coning beat stays; each filter's
    linear trend removed, as in the fit of its beat), with the closed-form beat amplitude
    ``+- a_a a_b (w_a + w_b) / (4 |w_a - w_b|)`` (linear scale).

    ``coning``: the run's ``metrics.json`` ``block.dither_coning`` (``sins_sim.jobs.run``).
    """
    plt = _pyplot(headless=path is not None)
    names = [n for n in res.filters if n != "raw" and n in res.series and res.series[n]["t_s"].size]
    fig, axes = plt.subplots(len(coning), 1, figsize=(10, 3.6 + 2.6 * len(coning)), squeeze=False,
                             layout="constrained")
    for ax, cn in zip(axes[:, 0], coning):
        c = "xyz".index(cn["about"])
        beat = cn["beat_closed_form_arcsec"]
        for name in names:
            ser = res.series[name]
            t = np.asarray(ser["t_s"])
            # body axis c at rest and level: NED turned by the heading about down (as the metrics)
            y = level_body_from_ned(ser["attitude_ned_rad"], cn["heading_rad"])[:, c] / ARCSEC
            meas = cn["beat_in_attitude_error_arcsec"].get(name)
            lab = filter_label(name) + ("" if meas is None else f" (beat {meas:.3g} arcsec)")
            ax.plot(t, y - np.polyval(np.polyfit(t, y, 1), t), label=lab, lw=1.2, **{k: v for k, v in line_style(name).items() if k != "lw"})
        for sgn in (1.0, -1.0):
            ax.axhline(sgn * beat, color="0.25", ls=":", lw=1.2,
                       label=f"closed-form beat +-{beat:.3g} arcsec" if sgn > 0 else "_")
        a, b = cn["pair"]
        ax.set_ylabel(f"error about {cn['about']}, trend removed\n(arcsec)")
        ax.set_title(f"gyros {a} and {b} {cn['separation_hz']:.4g} Hz apart: coning about {cn['about']}", fontsize=9)
        ax.grid(True, alpha=0.3)
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo, hi + 0.6 * (hi - lo))  # headroom above the data for the legend
        ax.legend(fontsize=7.5, loc="upper center", ncol=2)
    axes[-1, 0].set_xlabel("time (s)")
    rate = coning[0]["series_rate_hz"]
    fig.suptitle(f"{title}\n(means over {1.0 / rate:.3g} s intervals; the dither lines average out, the beat stays)",
                 fontsize=10)
    return finish_figure(fig, path)
