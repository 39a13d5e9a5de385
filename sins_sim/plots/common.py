"""Plots (matplotlib, imported lazily with the Agg backend so no display is needed)."""

from __future__ import annotations

import numpy as np

from sins_sim.units import ARCMIN, ARCSEC

LABELS = {
    "raw": "raw readout",
    "eliminator": "elliptic eliminator",
    "correcting": "correcting eq. 5, unity DC",
    "correcting_paper": "correcting eq. 5, paper form",
    "truth": "true SINS angle",
}
COLORS = {"raw": "0.6", "eliminator": "tab:red", "correcting": "tab:blue", "correcting_paper": "tab:cyan",
          "truth": "k"}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def plot_channel(result, path, window_s: float = 0.03, settle_s: float = 0.0, title: str = "") -> None:
    """Three panels: raw readout vs truth, filter outputs vs truth, residuals; last ``window_s`` seconds."""
    plt = _pyplot()
    t = result.t
    sel = t >= max(t[-1] - window_s, settle_s)
    tm = (t[sel] - t[sel][0]) * 1e3
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True, constrained_layout=True)
    ax = axes[0]
    ax.plot(tm, result.outputs["raw"][sel] / ARCMIN, color=COLORS["raw"], lw=1.0, label=LABELS["raw"])
    ax.plot(tm, result.truth("raw")[sel] / ARCMIN, color="k", lw=1.2, ls="--", label=LABELS["truth"])
    ax.set_ylabel("angle (arcmin)")
    ax.set_title("RLG readout: dither on top of the SINS motion")
    ax.legend(loc="upper right")
    ax = axes[1]
    ax.plot(tm, result.truth("correcting")[sel] / ARCSEC, color="k", lw=2.2, alpha=0.35,
            label=LABELS["truth"] + " (aligned)")
    for name in ("eliminator", "correcting", "correcting_paper"):
        ax.plot(tm, result.outputs[name][sel] / ARCSEC, color=COLORS[name], lw=1.0, label=LABELS[name])
    ax.set_ylabel("angle (arcsec)")
    ax.set_title("Dither removed: filter outputs and the true SINS angle")
    ax.legend(loc="upper right", fontsize=8)
    ax = axes[2]
    rms = result.residual_rms(settle_s)
    for name in ("eliminator", "correcting", "correcting_paper"):
        ax.plot(tm, result.residual(name)[sel] / ARCSEC, color=COLORS[name], lw=1.0,
                label=f"{LABELS[name]}: RMS {rms[name] / ARCSEC:.3g} arcsec")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_ylabel("output - truth (arcsec)")
    ax.set_xlabel(f"time from t = {t[sel][0]:.3f} s (ms)")
    ax.set_title("Residual after time alignment (RMS over the whole run after settling)")
    ax.legend(loc="upper right", fontsize=8)
    if title:
        fig.suptitle(title)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def spectrum_db(x, fs):
    """One-sided amplitude spectrum (Hann window) in dB re 1 arcsec: (f, dB)."""
    x = np.asarray(x, dtype=np.float64)
    x = x - x.mean()
    w = np.hanning(x.size)
    spec = np.abs(np.fft.rfft(x * w)) * 2.0 / w.sum()
    f = np.fft.rfftfreq(x.size, 1.0 / fs)
    return f, 20.0 * np.log10(np.maximum(spec / ARCSEC, 1e-12))


SINS_LABELS = {"ideal": "ideal increments (algorithm floor)", **LABELS}
SINS_COLORS = {"ideal": "k", **COLORS}


def plot_attitude_error(result, path, title: str = "") -> None:
    """Roll, pitch, yaw error (arcsec) vs time for each filter."""
    plt = _pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True, constrained_layout=True)
    for i, comp in enumerate(("roll", "pitch", "yaw")):
        ax = axes[i]
        order = sorted(result.attitude_error, key=lambda n: n == "correcting")  # unity form on top
        for name in order:
            y = result.attitude_error[name][:, i] / ARCSEC
            if name == "raw":  # the dither itself, hundreds of arcsec: named in the legend, not drawn
                ax.plot([], [], color=SINS_COLORS["raw"],
                        label=f"{SINS_LABELS['raw']}: not drawn, RMS {np.sqrt(np.mean(y * y)):.3g} arcsec")
                continue
            ax.plot(result.t, y, color=SINS_COLORS.get(name, None), lw=1.0, label=SINS_LABELS.get(name, name))
        ax.set_ylabel(f"{comp} error (arcsec)")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper left", fontsize=8, ncol=2)
    axes[-1].set_xlabel("time (s)")
    axes[0].set_title(title or "Attitude error of the strapdown solution, per dither filter")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _welch_amplitude_db(x, fs):
    """Welch-averaged amplitude spectrum (Hann, 'spectrum' scaling) in dB re 1 arcsec: a sine of
    amplitude A reads 20 log10(A / 1 arcsec) at its frequency."""
    from scipy import signal

    x = np.asarray(x, dtype=np.float64)
    nper = int(min(4096, x.size))
    f, p = signal.welch(x - x.mean(), fs=fs, window="hann", nperseg=nper, scaling="spectrum")
    return f, 20.0 * np.log10(np.maximum(np.sqrt(2.0 * p) / ARCSEC, 1e-12))


def plot_output_spectra(result, path, title: str = "") -> None:
    """Amplitude spectrum of each filter's gyro-angle output vs the truth, per axis (Welch, log frequency)."""
    plt = _pyplot()
    spec = result.spectra
    fs = result.filter_rate_hz
    fig, axes = plt.subplots(3, 1, figsize=(10, 10), sharex=True, constrained_layout=True)
    drives = {d["axis"]: d["frequency_hz"] for d in getattr(result, "drives", [])}
    for i, axis in enumerate(("x", "y", "z")):
        ax = axes[i]
        if spec["truth"].shape[0] < 64:
            continue
        for name in [n for n in ("raw", "eliminator", "correcting_paper", "correcting") if n in spec]:
            f, db = _welch_amplitude_db(spec[name][:, i], fs)
            ax.semilogx(f[1:], db[1:], color=SINS_COLORS.get(name), lw=1.6 if name == "correcting" else 1.0,
                        alpha=0.5 if name == "raw" else 1.0, label=SINS_LABELS.get(name, name))
        f, db = _welch_amplitude_db(spec["truth"][:, i], fs)
        ax.semilogx(f[1:], db[1:], color="k", lw=1.2, ls="--", label="true SINS angle")
        if axis in drives:
            ax.axvline(drives[axis], color="0.5", lw=0.8, ls=":")
            ax.text(drives[axis], 52, f" dither {drives[axis]:.0f} Hz", fontsize=8, color="0.4", va="top")
        ax.set_ylabel(f"gyro {axis}: amplitude\n(dB re 1 arcsec)")
        ax.set_ylim(-90, 60)
        ax.set_xlim(f[1], fs / 2)
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(loc="lower left", fontsize=8, ncol=2)
    axes[-1].set_xlabel("frequency (Hz)")
    axes[0].set_title(title or "Spectrum of each filter's output against the true block angle")
    fig.savefig(path, dpi=120)
    plt.close(fig)
