"""Figures of a navigation run (``sins-sim run``): errors against time, path, gyro-error spectra.

The stored series are block means with their min/max envelope (see
:mod:`sins_sim.simulation.metrics`): lines show the means, shaded bands the envelopes, so
nothing between two stored samples is hidden or aliased.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.plots.common import COLORS, LABELS, _pyplot
from sins_sim.units import ARCSEC

__all__ = ["plot_run", "plot_navigation_error", "plot_attitude_error", "plot_trajectory", "plot_gyro_error_spectrum"]

NAV_LABELS = {"ideal": "ideal increments (algorithm floor)", **LABELS}
NAV_COLORS = {"ideal": "k", **COLORS}
_NED = ("north", "east", "down (heading)")


def _time_axis(t):
    """Seconds or minutes, whichever reads better."""
    if t.size and t[-1] > 600:
        return t / 60.0, "time (min)"
    return t, "time (s)"


def plot_run(res, out, name: str) -> list:
    """All figures of a run into folder ``out``; returns their file names."""
    figs = []
    if res.series:
        plot_navigation_error(res, out / "navigation_error.png", f"{name}: navigation error against truth")
        plot_attitude_error(res, out / "attitude_error.png", f"{name}: attitude error psi (NED) against truth")
        plot_trajectory(res, out / "trajectory.png", f"{name}: path and horizontal error")
        figs += ["navigation_error.png", "attitude_error.png", "trajectory.png"]
    if res.spectra and res.spectra.get("t") is not None and res.spectra["t"].size > 64:
        plot_gyro_error_spectrum(res, out / "gyro_error_spectrum.png",
                                 f"{name}: gyro-angle error (output - truth) amplitude density")
        figs.append("gyro_error_spectrum.png")
    gyro_allan = {n: a for n, a in getattr(res, "allan", {}).items() if n in res.filters}
    if gyro_allan:
        from sins_sim.plots.allan import plot_allan_filters

        plot_allan_filters(gyro_allan, out / "allan.png",
                           f"{name}: Allan deviation of each filter's gyro error ({res.allan['record_s']:.4g} s at "
                           f"{res.allan['rate_hz']:.3g} Hz)", NAV_COLORS, NAV_LABELS)
        figs.append("allan.png")
    return figs


def plot_navigation_error(res, path, title: str = "") -> None:
    """Horizontal position error (log), vertical error and velocity error against time, per filter."""
    plt = _pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    for name, ser in res.series.items():
        t, xlabel = _time_axis(ser["t_s"])
        c = NAV_COLORS.get(name)
        lab = NAV_LABELS.get(name, name)
        h, hmin, hmax = ser["horizontal_m"], ser["horizontal_m_min"], ser["horizontal_m_max"]
        floor = 1e-6
        axes[0].plot(t, np.maximum(h, floor), color=c, lw=1.2, label=lab)
        axes[0].fill_between(t, np.maximum(hmin, floor), np.maximum(hmax, floor), color=c, alpha=0.15, lw=0)
        axes[1].plot(t, ser["vertical_m"], color=c, lw=1.0, label=lab)
        vel = np.linalg.norm(ser["velocity_ned_m_s"], axis=1)
        axes[2].plot(t, np.maximum(vel, floor), color=c, lw=1.0, label=lab)
    axes[0].set_yscale("log")
    axes[0].set_ylabel("horizontal position\nerror (m)")
    axes[1].set_yscale("symlog", linthresh=1e-3, linscale=0.5)
    axes[1].set_ylabel("height error (m, up)\n(symmetric log, linear within 1 mm)")
    axes[2].set_yscale("log")
    axes[2].set_ylabel("velocity error |dv| (m/s)\n(block means)")
    axes[2].set_xlabel(xlabel)
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8, loc="best")
    axes[0].set_title(title + "\n(lines: means over each stored interval; bands: min to max)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_attitude_error(res, path, title: str = "") -> None:
    """Attitude error psi about north, east and down against time, per filter, in arcsec."""
    plt = _pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    hidden = []
    for name, ser in res.series.items():
        t, xlabel = _time_axis(ser["t_s"])
        a = ser["attitude_ned_rad"] / ARCSEC
        if name == "raw":  # the raw readout carries the dither: its error would swamp the filters'
            hidden.append(f"raw readout not drawn: RMS {np.sqrt(np.mean(a * a)):.3g} arcsec")
            continue
        lo, hi = ser["attitude_ned_rad_min"] / ARCSEC, ser["attitude_ned_rad_max"] / ARCSEC
        for i, ax in enumerate(axes):
            ax.plot(t, a[:, i], color=NAV_COLORS.get(name), lw=1.0, label=NAV_LABELS.get(name, name))
            ax.fill_between(t, lo[:, i], hi[:, i], color=NAV_COLORS.get(name), alpha=0.12, lw=0)
    for i, ax in enumerate(axes):
        # filters differ by decades: symmetric log scale, linear within +-0.1 arcsec
        ax.set_yscale("symlog", linthresh=0.1, linscale=0.5)
        ax.set_ylabel(f"psi {_NED[i]} (arcsec)")
        ax.grid(True, which="major", alpha=0.3)
    axes[-1].set_xlabel(xlabel)
    axes[0].legend(fontsize=8, loc="best", title="; ".join(hidden) if hidden else None, title_fontsize=8)
    axes[0].set_title(title + "\n(symmetric log scale, linear within +-0.1 arcsec; bands: min to max)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_trajectory(res, path, title: str = "") -> None:
    """Left: the true path (north/east from the start); right: each filter's horizontal error (north, east)."""
    plt = _pyplot()
    from sins_sim import earth

    fig, (a0, a1) = plt.subplots(1, 2, figsize=(12, 5.5))
    ts = res.truth_series
    if ts["t_s"].size:
        lat0, lon0 = ts["lat_rad"][0], ts["lon_rad"][0]
        n, e, _ = earth.horizontal_error_m(ts["lat_rad"], ts["lon_rad"], lat0, lon0, ts["h_m"][0])
        span = max(float(np.ptp(n)), float(np.ptp(e)))
        unit, scale = ("km", 1e-3) if span > 5e3 else ("m", 1.0)
        a0.plot(e * scale, n * scale, color="k", lw=1.5, label="truth")
        a0.plot(e[:1] * scale, n[:1] * scale, "o", color="k", label="start")
        a0.set_xlabel(f"east of the start ({unit})")
        a0.set_ylabel(f"north of the start ({unit})")
        a0.set_aspect("equal", adjustable="datalim")
        a0.legend(fontsize=8)
        a0.set_title("true path", fontsize=10)
        a0.grid(True, alpha=0.3)
    for name, ser in res.series.items():
        if name == "raw":
            continue
        a1.plot(ser["east_m"], ser["north_m"], color=NAV_COLORS.get(name), lw=1.0, label=NAV_LABELS.get(name, name))
        a1.plot(ser["east_m"][-1:], ser["north_m"][-1:], "o", color=NAV_COLORS.get(name), ms=4)
    a1.set_xscale("symlog", linthresh=0.01, linscale=0.5)
    a1.set_yscale("symlog", linthresh=0.01, linscale=0.5)
    a1.set_xlabel("east error (m, symmetric log, linear within +-1 cm)")
    a1.set_ylabel("north error (m, symmetric log)")
    a1.set_title("each filter's position minus truth (dot: end)", fontsize=10)
    a1.grid(True, alpha=0.3)
    a1.legend(fontsize=8)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_gyro_error_spectrum(res, path, title: str = "") -> None:
    """Amplitude spectral density of each filter's gyro-angle error, per axis (arcsec/sqrt(Hz))."""
    plt = _pyplot()
    from scipy import signal

    fs = res.filter_rate_hz
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    nper = int(min(res.spectra["t"].size, 2 ** int(math.log2(max(64, fs / 2)))))
    for name, err in res.spectra.items():
        if name in ("t", "ideal") or err.shape[0] < nper:
            continue
        f, p = signal.welch(err / ARCSEC, fs=fs, nperseg=nper, axis=0, detrend="linear")
        for i, ax in enumerate(axes):
            ax.loglog(f[1:], np.sqrt(p[1:, i]), color=NAV_COLORS.get(name), lw=1.0, label=NAV_LABELS.get(name, name))
    for i, ax in enumerate(axes):
        ax.set_ylabel(f"gyro {'xyz'[i]}\n(arcsec/sqrt(Hz))")
        ax.grid(True, which="both", alpha=0.3)
        for d in res.drives[i:i + 1]:
            ax.axvline(d["frequency_hz"], color="0.5", ls=":", lw=1.0)
            ax.text(d["frequency_hz"], ax.get_ylim()[1], " dither", fontsize=7, color="0.4", va="top")
    axes[-1].set_xlabel("frequency (Hz)")
    axes[0].legend(fontsize=8, loc="lower left")
    axes[0].set_title(title + f"\n(Welch, {nper} samples per segment, over {res.spectra['t'].size / fs:g} s)",
                      fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
