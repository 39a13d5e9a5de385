"""Figures of a navigation run (``sins-sim run``): errors against time, path, gyro-error spectra.

The stored series are block means with their min/max envelope (see
:mod:`sins_sim.simulation.metrics`): lines show the means, light bands behind them the envelopes in
the same colour, so nothing between two stored samples is hidden or aliased. Colours and labels
come from :mod:`sins_sim.plots.common` (one map for every figure); a figure without data is not
written. Every ``plot_*`` function returns its matplotlib Figure: given a ``path`` it writes the
figure there and closes it (the CLI), without one it leaves it open (a notebook,
:meth:`sins_sim.results.MissionResult.plot`).
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.plots.common import (ENVELOPE_ALPHA, draw_envelope, filter_color, filter_label, line_style,
                                   _pyplot, finish_figure, symlog_threshold)
from sins_sim.units import ARCSEC

__all__ = ["plot_run", "run_figure", "available_figures", "plot_navigation_error", "plot_attitude_error", "plot_trajectory", "plot_gyro_error_spectrum",
           "spectrum_settings", "RUN_FIGURES"]

#: Every figure ``sins-sim run`` can write, in the order written; each only when it has data.
RUN_FIGURES = ("navigation_error.png", "attitude_error.png", "trajectory.png", "gyro_error_spectrum.png",
               "allan.png", "block_spectrum.png", "block_coning.png")
_NED = ("north", "east", "down")
#: Welch segment length of the gyro-error spectrum (s), when the record is long enough; 50 % overlap.
SPECTRUM_SEGMENT_S = 0.25


def _time_axis(t):
    """Seconds or minutes, whichever reads better."""
    if t.size and t[-1] > 600:
        return t / 60.0, "time (min)"
    return t, "time (s)"


def _positive(x):
    """``x`` with its non-positive values masked (NaN) for a logarithmic axis."""
    x = np.asarray(x, dtype=float)
    return np.where(x > 0.0, x, np.nan)


def _drawn(res):
    """The filters whose navigation series are drawn (not ``raw``: its dither swamps every other curve)."""
    return [n for n, ser in res.series.items() if n != "raw" and ser["t_s"].size]


def _spectrum_filters(res):
    """The filters whose gyro-angle error has a spectrum: not ``ideal`` (its error is zero by construction)."""
    sp = res.spectra or {}
    return [n for n, e in sp.items() if n not in ("t", "ideal") and e.shape[0] and np.any(e != 0.0)]


def spectrum_settings(res) -> dict | None:
    """The Welch settings of the gyro-error spectrum of ``res``, or None when there is nothing to analyse.

    Returns
    -------
    dict or None
        ``nperseg`` (samples), ``segment_s``, ``overlap`` (fraction), ``window`` and the analysed span
        ``t0_s``, ``t1_s``, ``span_s``; None when no filter other than ``ideal`` has an error record of at
        least 64 samples.
    """
    sp = res.spectra or {}
    t = sp.get("t")
    if t is None or t.size < 64 or not _spectrum_filters(res):
        return None
    fs = float(res.filter_rate_hz)
    nper = int(min(t.size, 2 ** int(round(math.log2(max(64.0, SPECTRUM_SEGMENT_S * fs))))))
    return {"nperseg": nper, "segment_s": nper / fs, "overlap": 0.5, "window": "Hann", "t0_s": float(t[0]),
            "t1_s": float(t[-1] + 1.0 / fs), "span_s": t.size / fs}


def _gyro_allan(res) -> dict:
    """The filters' gyro Allan analyses of ``res`` (not the accelerometers'), or {}."""
    return {n: a for n, a in (getattr(res, "allan", None) or {}).items() if n in res.filters}


def available_figures(res, metrics: dict | None = None) -> list:
    """The kinds of :data:`RUN_FIGURES` (file names without ``.png``) that ``res`` has data for, in order.

    ``block_coning`` needs the run's metrics (``metrics.json``: ``block.dither_coning``).

    A figure without data is not drawn (e.g. ``filters: [ideal]`` has no gyro-error spectrum: the
    ideal increments have no error; a result read back from a folder has no Allan curves).
    """
    kinds = []
    if _drawn(res):
        kinds += ["navigation_error", "attitude_error", "trajectory"]
    if spectrum_settings(res) is not None:
        kinds.append("gyro_error_spectrum")
    gyro_allan = _gyro_allan(res)
    if gyro_allan:
        from sins_sim.plots.allan import has_curves

        if has_curves(gyro_allan):
            kinds.append("allan")
    blk = getattr(res, "block", None)
    if blk is not None and blk["theta_rad"].shape[0] >= 128:
        kinds.append("block_spectrum")
    if ((metrics or {}).get("block") or {}).get("dither_coning") and _drawn(res):
        kinds.append("block_coning")
    return kinds


def run_figure(res, kind: str, name: str, path=None, metrics: dict | None = None):
    """One figure of a run by its kind (a :data:`RUN_FIGURES` name without ``.png``); returns the Figure.

    Parameters
    ----------
    res : SinsResult
        Or anything with its ``series``, ``truth_series``, ``spectra``, ``filters``, ``filter_rate_hz``,
        ``drives`` and ``allan``.
    kind : str
    name : str
        The scenario's name, for the title.
    path : path, optional
        Write the figure there and close it; None (default) leaves it open.
    metrics : dict, optional
        The run's metrics (``metrics.json``), which ``block_coning`` needs.
    """
    if kind == "navigation_error":
        return plot_navigation_error(res, path, f"{name}: navigation error against truth")
    if kind == "attitude_error":
        return plot_attitude_error(res, path, f"{name}: attitude error phi (NED) against truth")
    if kind == "trajectory":
        return plot_trajectory(res, path, f"{name}: path and horizontal position error")
    if kind == "gyro_error_spectrum":
        return plot_gyro_error_spectrum(res, path,
                                        f"{name}: gyro-angle error (output - truth), amplitude spectral density")
    if kind == "allan":
        from sins_sim.plots.allan import plot_allan_filters

        return plot_allan_filters(_gyro_allan(res), path,
                                  f"{name}: Allan deviation of each filter's gyro error ({res.allan['record_s']:.4g} s "
                                  f"at {res.allan['rate_hz']:.3g} Hz)")
    if kind == "block_spectrum":
        from sins_sim.plots.block import plot_block_spectrum

        return plot_block_spectrum(res, path, f"{name}: the block's own rotation on its isolators, amplitude spectral "
                                              "density")
    if kind == "block_coning":
        from sins_sim.plots.block import plot_block_coning

        blk = (metrics or {}).get("block") or {}
        if not blk.get("dither_coning"):
            raise ValueError("block_coning: needs the run's metrics with block.dither_coning (a block whose dithers "
                             "beat slowly enough for the stored series)")
        return plot_block_coning(res, blk["dither_coning"], path, f"{name}: dither coning in each filter's attitude "
                                                                 "error")
    raise ValueError(f"unknown figure {kind!r}: one of {[k[:-4] for k in RUN_FIGURES]}")


def plot_run(res, out, name: str, metrics: dict | None = None) -> list:
    """The figures of a run that have data (:func:`available_figures`), into folder ``out``; returns their file names."""
    figs = []
    for kind in available_figures(res, metrics):
        run_figure(res, kind, name, out / f"{kind}.png", metrics)
        figs.append(f"{kind}.png")
    return figs


def _legend_below(fig, axes, extra: str = "") -> None:
    """One legend for the figure, outside the data area (below the panels), with the envelope explained."""
    handles, labels = [], []
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            if lab not in labels and not lab.startswith("_"):
                handles.append(h)
                labels.append(lab)
    if not handles:
        return
    from matplotlib.patches import Patch

    handles.append(Patch(color="0.5", alpha=ENVELOPE_ALPHA * 3, lw=0))
    labels.append("band: min to max within each stored interval (filter's colour)" + extra)
    fig.legend(handles, labels, loc="outside lower center", ncol=min(3, len(handles)), fontsize=8, frameon=False)


def plot_navigation_error(res, path=None, title: str = ""):
    """Horizontal position error (log), height error (symmetric log) and velocity error (log) per filter.

    Lines are the means over each stored interval, bands (light, behind) the min/max within it.
    """
    plt = _pyplot(headless=path is not None)
    fig, axes = plt.subplots(3, 1, figsize=(10, 10), sharex=True, layout="constrained")
    names = _drawn(res)
    xlabel = "time (s)"
    for name in names:
        ser = res.series[name]
        t, xlabel = _time_axis(ser["t_s"])
        st = line_style(name)
        lab = filter_label(name)
        # log axes: a zero (the aligned start) is left out, not clipped to an invented floor
        draw_envelope(axes[0], t, _positive(ser["horizontal_m_min"]), _positive(ser["horizontal_m_max"]), name)
        axes[0].plot(t, _positive(ser["horizontal_m"]), label=lab, **st)
        draw_envelope(axes[1], t, ser["vertical_m_min"], ser["vertical_m_max"], name)
        axes[1].plot(t, ser["vertical_m"], label=lab, **st)
        vel = np.linalg.norm(ser["velocity_ned_m_s"], axis=1)
        axes[2].plot(t, _positive(vel), label=lab, **st)
    lin = symlog_threshold([res.series[n]["vertical_m"] for n in names])
    axes[0].set_yscale("log")
    axes[0].set_ylabel("horizontal position error (m)\n(log scale)")
    axes[1].set_yscale("symlog", linthresh=lin, linscale=1.0)
    axes[1].set_ylabel(f"height error, up (m)\n(symmetric log: linear within +-{lin:g} m)")
    axes[2].set_yscale("log")
    axes[2].set_ylabel("velocity error |dv| (m/s)\n(log scale, means only)")
    axes[2].set_xlabel(xlabel)
    for ax in axes:
        ax.grid(True, which="major", alpha=0.3)
    axes[0].set_title(title + "\n(lines: means over each stored interval)", fontsize=10)
    _legend_below(fig, axes[:1])
    return finish_figure(fig, path)


def plot_attitude_error(res, path=None, title: str = ""):
    """Attitude error phi about north, east and down against time, per filter, in arcsec.

    phi is the rotation vector of q_est (x) q_true*: the misalignment of the computed NED frame against
    the true NED frame at the true position, per NED axis. The axis is symmetric-logarithmic with its
    linear half-width taken from the data (:func:`sins_sim.plots.common.symlog_threshold`), and says so.
    """
    plt = _pyplot(headless=path is not None)
    fig, axes = plt.subplots(3, 1, figsize=(10, 10), sharex=True, layout="constrained")
    hidden = ""
    if "raw" in res.series and res.series["raw"]["t_s"].size:
        a = res.series["raw"]["attitude_ned_rad"] / ARCSEC
        hidden = f"; raw readout not drawn (its dither swamps the filters): RMS {np.sqrt(np.mean(a * a)):.3g} arcsec"
    names = _drawn(res)
    xlabel = "time (s)"
    for name in names:
        ser = res.series[name]
        t, xlabel = _time_axis(ser["t_s"])
        a = ser["attitude_ned_rad"] / ARCSEC
        lo, hi = ser["attitude_ned_rad_min"] / ARCSEC, ser["attitude_ned_rad_max"] / ARCSEC
        for i, ax in enumerate(axes):
            draw_envelope(ax, t, lo[:, i], hi[:, i], name)
            ax.plot(t, a[:, i], label=filter_label(name), **line_style(name))
    lin = symlog_threshold([res.series[n]["attitude_ned_rad"] / ARCSEC for n in names])
    for i, ax in enumerate(axes):
        ax.set_yscale("symlog", linthresh=lin, linscale=1.0)
        ax.set_ylabel(f"phi {_NED[i]} (arcsec)")
        ax.grid(True, which="major", alpha=0.3)
    axes[-1].set_xlabel(xlabel)
    axes[0].set_title(f"{title}\nphi: rotation vector of q_est x q_true*, the computed NED frame against the true "
                      f"one\n(symmetric log scale: linear within +-{lin:g} arcsec, logarithmic outside; "
                      f"lines: means over each stored interval)", fontsize=10)
    _legend_below(fig, axes[:1], hidden)
    return finish_figure(fig, path)


def _length_unit(extent_m: float):
    """(unit, metres per unit) so that ``extent_m`` reads between 1 and 1000."""
    for unit, size in (("km", 1e3), ("m", 1.0), ("cm", 1e-2), ("mm", 1e-3), ("um", 1e-6)):
        if extent_m >= size:
            return unit, size
    return "nm", 1e-9


def plot_trajectory(res, path=None, title: str = ""):
    """Left: the true path (north/east of the start); right: each filter's horizontal error track in its own panel.

    Every panel keeps the geometry: linear axes with equal aspect, the unit chosen per panel (stated on
    its axes) because the filters' errors differ by decades.
    """
    plt = _pyplot(headless=path is not None)
    from sins_sim import earth

    names = _drawn(res)
    ncol = max(1, math.ceil(len(names) / 2))
    fig = plt.figure(figsize=(6.0 + 3.6 * ncol, 6.4), layout="constrained")
    gs = fig.add_gridspec(2, 1 + ncol, width_ratios=[1.7] + [1.0] * ncol)
    a0 = fig.add_subplot(gs[:, 0])
    ts = res.truth_series
    if ts["t_s"].size:
        lat0, lon0 = ts["lat_rad"][0], ts["lon_rad"][0]
        n, e, _ = earth.horizontal_error_m(ts["lat_rad"], ts["lon_rad"], lat0, lon0, ts["h_m"][0])
        span = max(float(np.ptp(n)), float(np.ptp(e)), 1e-3)
        unit, size = ("km", 1e3) if span > 5e3 else _length_unit(span)
        a0.plot(e / size, n / size, color="k", lw=1.5, label="true path")
        a0.plot(e[:1] / size, n[:1] / size, "o", color="k", label="start")
        a0.plot(e[-1:] / size, n[-1:] / size, "s", color="k", mfc="none", label="end")
        a0.set_xlabel(f"east of the start ({unit})")
        a0.set_ylabel(f"north of the start ({unit})")
        a0.set_aspect("equal", adjustable="datalim")
        a0.legend(fontsize=8, loc="best")
    a0.set_title("true path (equal scales)", fontsize=10)
    a0.grid(True, alpha=0.3)
    for k, name in enumerate(names):
        ax = fig.add_subplot(gs[k % 2, 1 + k // 2])
        ser = res.series[name]
        east, north = ser["east_m"], ser["north_m"]
        extent = max(float(np.max(np.abs(east))), float(np.max(np.abs(north))), 1e-9)
        unit, size = _length_unit(extent)
        st = line_style(name)
        ax.plot(east / size, north / size, **st)
        ax.plot([0.0], [0.0], "o", color="0.4", ms=4)
        ax.plot(east[-1:] / size, north[-1:] / size, "s", color=st["color"], ms=5)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(f"east error ({unit})", fontsize=8)
        ax.set_ylabel(f"north error ({unit})", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_title(f"{filter_label(name)}\nend: {math.hypot(east[-1], north[-1]):.3g} m", fontsize=8,
                     color=st["color"] if name != "ideal" else "k")
        ax.grid(True, alpha=0.3)
    fig.suptitle(title + "\nright: each filter's position minus truth from the navigation start (dot) to the end "
                 "(square), equal scales, unit per panel", fontsize=10)
    return finish_figure(fig, path)


def plot_gyro_error_spectrum(res, path=None, title: str = ""):
    """Amplitude spectral density of each filter's gyro-angle error, per axis (arcsec/sqrt(Hz)).

    Welch's method (Hann window, 50 % overlap, linear detrend, one-sided density) over the stored
    full-rate record; the window length and the time span analysed are stated on the figure.
    """
    plt = _pyplot(headless=path is not None)
    from scipy import signal

    cfg = spectrum_settings(res)
    if cfg is None:
        raise ValueError("plot_gyro_error_spectrum: no gyro-error record to analyse")
    fs = res.filter_rate_hz
    nper = cfg["nperseg"]
    fig, axes = plt.subplots(3, 1, figsize=(10, 10), sharex=True, layout="constrained")
    for name in _spectrum_filters(res):
        err = res.spectra[name]
        f, p = signal.welch(err / ARCSEC, fs=fs, window="hann", nperseg=nper, noverlap=nper // 2, axis=0,
                            detrend="linear")
        for i, ax in enumerate(axes):
            y = np.sqrt(p[1:, i])
            ok = y > 0
            if np.any(ok):
                ax.loglog(f[1:][ok], y[ok], label=filter_label(name), **line_style(name))
    for i, ax in enumerate(axes):
        ax.set_ylabel(f"gyro {'xyz'[i]}: error ASD\n(arcsec/sqrt(Hz))")
        ax.grid(True, which="major", alpha=0.3)
        for d in res.drives[i:i + 1]:
            ax.axvline(d["frequency_hz"], color="0.5", ls=":", lw=1.0, zorder=0)
            ax.annotate(f" dither {d['frequency_hz']:.0f} Hz", (d["frequency_hz"], 1.0),
                        xycoords=("data", "axes fraction"), fontsize=7, color="0.35", va="top")
    axes[-1].set_xlabel("frequency (Hz)")
    axes[0].set_title(f"{title}\n(Welch: {cfg['window']} window of {nper} samples = {cfg['segment_s']:.3g} s, "
                      f"{cfg['overlap']:.0%} overlap, linear detrend; record t = {cfg['t0_s']:.4g}-"
                      f"{cfg['t1_s']:.4g} s, {cfg['span_s']:.3g} s at {fs:g} Hz)", fontsize=10)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(4, len(handles)), fontsize=8, frameon=False)
    return finish_figure(fig, path)
