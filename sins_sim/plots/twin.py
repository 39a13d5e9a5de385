"""Figures of ``sins-sim identify``: the PSD with its lines, and the log beside its twin.

Reads the objects of :mod:`sins_sim.navigation.spectral_lines` and the dict bands of
:mod:`sins_sim.identification.twin_gap` through their attributes and keys only (this module imports no physics).
Spectra are drawn as amplitude spectral densities, ``sqrt(PSD)``: deg/h/sqrt(Hz) for gyros, ug/sqrt(Hz) for
accelerometers. matplotlib is imported lazily (Agg backend for files).

.. autosummary::

   plot_psd_lines
   plot_twin_allan
   plot_twin_psd
   plot_twin_nav
   plot_twin_alignment
   plot_twin_shrink
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.plots.common import _pyplot, finish_figure
from sins_sim.units import ARCSEC, DEG_PER_H, MICRO_G

__all__ = ["plot_psd_lines", "plot_twin_alignment", "plot_twin_allan", "plot_twin_nav", "plot_twin_psd",
           "plot_twin_shrink"]

_SCALE = {"gyro": (1.0 / DEG_PER_H, "deg/h"), "accelerometer": (1.0 / MICRO_G, "ug")}
LOG_COLOR, TWIN_COLOR, OUT_COLOR = "black", "tab:blue", "tab:red"


def _grid(plt, rows=2, cols=3, size=(5.0, 3.9)):
    return plt.subplots(rows, cols, figsize=(size[0] * cols, size[1] * rows), squeeze=False, constrained_layout=True)


def _panel(axes, sensor: str, ax_name: str):
    """The panel of a sensor axis: gyros on the top row, accelerometers below, x, y, z across."""
    return axes[0 if sensor == "gyro" else 1]["xyz".index(ax_name)]


def _sensor_panels(plt, by_channel: dict):
    """The 2 x 3 figure and, per ``(sensor, axis) -> item``, ``(key, item, panel, factor to the edge unit, unit)``."""
    fig, axes = _grid(plt)
    return fig, axes, [(key, item, _panel(axes, *key), *_SCALE[key[0]]) for key, item in by_channel.items()]


def _label(ax, title: str, xlabel: str, ylabel: str, which: str = "both") -> None:
    ax.set_title(title, fontsize=10)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which=which, alpha=0.25)


def _quiet(ax, title: str) -> None:
    """A channel with nothing to draw on a log scale: its readout never moved off one pulse count."""
    ax.set_title(title, fontsize=10)
    ax.text(0.5, 0.5, "no noise above the pulse weight:\nthe channel reads a constant count",
            ha="center", va="center", transform=ax.transAxes, fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])


def _finish(fig, axes, title: str, path, legend_size: float = 7.5, loc: str = "best"):
    axes[0][0].legend(fontsize=legend_size, loc=loc)
    if title:
        fig.suptitle(title, fontsize=11)
    return finish_figure(fig, path)


def _line_label(sensor: str, line) -> str:
    scale, unit = _SCALE[sensor]
    if sensor == "gyro":
        angle = line.amplitude / (2.0 * math.pi * line.frequency_hz) / ARCSEC
        return f"{line.frequency_hz:.3g} Hz\n{angle:.3g}\" ({line.amplitude * scale:.3g} {unit})"
    return f"{line.frequency_hz:.3g} Hz\n{line.amplitude * scale:.3g} {unit}"


def plot_psd_lines(searches: dict, path=None, title: str = ""):
    """The PSD of each sensor axis with its local floor, the detection threshold and the lines labelled.

    Parameters
    ----------
    searches : dict
        ``(sensor, axis) -> LineSearch`` (``sensor`` ``gyro`` or ``accelerometer``).
    path : path, optional
        The PNG to write (None: the figure is returned open).
    """
    fig, axes, panels = _sensor_panels(_pyplot(path is not None), searches)
    for (sensor, ax_name), s, ax, scale, unit in panels:
        f, p = s.psd.freq_hz[1:], s.psd.psd[1:]
        if not np.any(p > 0.0):
            _quiet(ax, f"{sensor} {ax_name}")
            continue
        ax.loglog(f, np.sqrt(p) * scale, color=LOG_COLOR, lw=0.6, label="PSD (Welch, Hann)")
        fl = s.floor[1:]
        ok = np.isfinite(fl)
        ax.loglog(f[ok], np.sqrt(fl[ok]) * scale, color="tab:green", lw=1.0, label="local floor")
        ax.loglog(f[ok], np.sqrt(fl[ok] * s.threshold) * scale, color="tab:orange", lw=0.9, ls="--",
                  label=f"threshold (x{s.threshold:.2g} in power)")
        top = float(np.max(np.sqrt(p))) * scale
        ax.set_ylim(top=top * 4.0)                     # room above the highest peak for its label
        right = math.sqrt(f[0] * f[-1])
        for line in s.lines:
            k = int(np.argmin(np.abs(s.psd.freq_hz - line.frequency_hz)))
            y = math.sqrt(s.psd.psd[k]) * scale
            ax.plot([line.frequency_hz], [y], "v", color=OUT_COLOR, ms=6)
            left = line.frequency_hz > right             # label to the left of a line in the upper half
            ax.annotate(_line_label(sensor, line), (line.frequency_hz, y), textcoords="offset points",
                        xytext=(-6 if left else 6, 2), ha="right" if left else "left", va="bottom", fontsize=7.5,
                        color=OUT_COLOR, bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "none", "alpha": 0.8})
        _label(ax, f"{sensor} {ax_name}: {len(s.lines)} line(s)", "frequency (Hz)", f"ASD ({unit}/sqrt(Hz))")
    return _finish(fig, axes, title, path, loc="upper right")


def plot_twin_allan(log_curves: dict, twin_curves: dict, bands: dict, path=None, title: str = ""):
    """The log's Allan deviation over its twin's seeds and band, the taus outside marked.

    Parameters
    ----------
    log_curves : dict
        ``(sensor, axis) -> AllanCurve`` of the log.
    twin_curves : dict
        ``(sensor, axis) -> list of AllanCurve`` (one per seed).
    bands : dict
        ``(sensor, axis) -> band`` (:func:`sins_sim.identification.twin_gap.allan_band`).
    """
    fig, axes, panels = _sensor_panels(_pyplot(path is not None), log_curves)
    for key, curve, ax, scale, unit in panels:
        sensor, ax_name = key
        if not np.any(curve.adev > 0.0):
            _quiet(ax, f"{sensor} {ax_name}")
            continue
        for j, c in enumerate(twin_curves[key]):
            ax.loglog(c.tau_s, c.adev * scale, color=TWIN_COLOR, lw=0.5, alpha=0.5,
                      label="twin seeds" if j == 0 else None)
        b = bands[key]
        t = b["tested"]
        ax.fill_between(b["tau_s"][t], b["lo"][t] * scale, b["hi"][t] * scale, color=TWIN_COLOR, alpha=0.18, lw=0,
                        label="twin band (tested taus)")
        ax.loglog(curve.tau_s, curve.adev * scale, color=LOG_COLOR, lw=1.3, label="log")
        out = b["outside"] != 0
        if np.any(out):
            ax.loglog(b["tau_s"][out], b["log"][out] * scale, "o", color=OUT_COLOR, ms=4, label="outside the band")
        _label(ax, f"{sensor} {ax_name}", "tau (s)", f"Allan deviation ({unit})")
    return _finish(fig, axes, title, path)


def _log_bands(f: np.ndarray, p: np.ndarray, per_decade: int) -> tuple:
    """Mean of ``p`` (last axis) in log-spaced frequency bands (for display): band centres and means."""
    edges = np.logspace(np.log10(f[0]), np.log10(f[-1]) + 1e-9, int(per_decade * np.log10(f[-1] / f[0])) + 2)
    idx = np.digitize(f, edges) - 1
    used = np.unique(idx)
    centres = np.array([np.exp(np.mean(np.log(f[idx == i]))) for i in used])
    means = np.stack([p[..., idx == i].mean(axis=-1) for i in used], axis=-1)
    return centres, means


def plot_twin_psd(log_searches: dict, twin_searches: dict, path=None, title: str = "", per_decade: int = 30):
    """The log's PSD over the min-max envelope of its twin's seeds (amplitude spectral density), each averaged in
    ``1 / per_decade``-decade bands for display (the lines found in the log marked by dotted verticals)."""
    fig, axes, panels = _sensor_panels(_pyplot(path is not None), log_searches)
    for key, s, ax, scale, unit in panels:
        sensor, ax_name = key
        f = s.psd.freq_hz[1:]
        if not np.any(s.psd.psd[1:] > 0.0):
            _quiet(ax, f"{sensor} {ax_name}")
            continue
        fc, tw = _log_bands(f, np.array([t.psd.psd[1:] for t in twin_searches[key]]), per_decade)
        _, lg = _log_bands(f, s.psd.psd[1:], per_decade)
        lo, hi = tw.min(axis=0), tw.max(axis=0)
        pos = lo > 0.0  # a twin without noise on the channel has no band to draw on a log scale
        if np.any(pos):
            ax.fill_between(fc[pos], np.sqrt(lo[pos]) * scale, np.sqrt(hi[pos]) * scale, color=TWIN_COLOR,
                            alpha=0.3, lw=0, label=f"twin, min-max of {tw.shape[0]} seeds")
        else:
            ax.plot([], [], color=TWIN_COLOR, label="twin: no noise on this channel")
        ax.loglog(fc, np.sqrt(lg) * scale, color=LOG_COLOR, lw=1.0,
                  label=f"log (means over 1/{per_decade} decade)")
        for line in s.lines:
            ax.axvline(line.frequency_hz, color=OUT_COLOR, lw=0.6, ls=":")
        _label(ax, f"{sensor} {ax_name}", "frequency (Hz)", f"ASD ({unit}/sqrt(Hz))")
    return _finish(fig, axes, title, path)


def plot_twin_nav(t_s, log_nav: dict, twin_navs: list, bands: dict, quantities, path=None, title: str = ""):
    """Free-navigation error of the log against its twin's seeds and envelope, one panel per quantity.

    Parameters
    ----------
    t_s : ndarray
        Times from the start of navigation (s).
    log_nav : dict
        The log's ``RestRun.nav``.
    twin_navs : list of dict
        Each seed's ``RestRun.nav``.
    bands : dict
        ``(key, column) -> band`` (:func:`sins_sim.identification.twin_gap.nav_band`).
    quantities : sequence
        ``(key, column, label, factor to the edge unit, unit)`` per panel.
    """
    plt = _pyplot(path is not None)
    n = len(quantities)
    cols = 4
    rows = -(-n // cols)
    fig, axes = _grid(plt, rows, cols, size=(4.2, 3.3))
    m = min([len(t_s)] + [tn[quantities[0][0]].shape[0] for tn in twin_navs])
    t = np.asarray(t_s[:m]) / 60.0
    for i, (key, col, label, scale, unit) in enumerate(quantities):
        ax = axes[i // cols][i % cols]
        for j, tn in enumerate(twin_navs):
            ax.plot(t, tn[key][:m, col] * scale, color=TWIN_COLOR, lw=0.5, alpha=0.5,
                    label="twin seeds" if j == 0 else None)
        b = bands[(key, col)]
        ax.fill_between(t, b["lo"][:m] * scale, b["hi"][:m] * scale, color=TWIN_COLOR, alpha=0.18, lw=0,
                        label="twin envelope")
        ax.plot(t, log_nav[key][:m, col] * scale, color=LOG_COLOR, lw=1.2, label="log")
        out = b["outside"][:m]
        if out[-1]:
            inside = np.flatnonzero(~out)
            start = int(inside[-1] + 1) if inside.size else 0
            ax.axvline(t[start], color=OUT_COLOR, lw=0.8, ls="--", label="leaves the envelope")
        _label(ax, label, "time (min)", unit, which="major")
    for k in range(n, rows * cols):
        axes[k // cols][k % cols].axis("off")
    return _finish(fig, axes, title, path, legend_size=7.0)


def plot_twin_alignment(side: dict, path=None, title: str = ""):
    """The twin's alignment errors per seed against the sigma the log's alignment states (and the twin's)."""
    plt = _pyplot(path is not None)
    fig, axes = plt.subplots(1, 3, figsize=(11.0, 3.4), squeeze=False, constrained_layout=True)
    keys = (("north_arcsec", "tilt about north", "arcsec"), ("east_arcsec", "tilt about east", "arcsec"),
            ("down_deg", "heading (about down)", "deg"))
    for ax, (key, label, unit) in zip(axes[0], keys):
        errs = [e[key] for e in side["twin_errors"]]
        x = np.arange(1, len(errs) + 1)
        s_log = side["log"]["sigma"][key]
        s_tw = side["twin_sigma_mean"][key]
        ax.axhspan(-2.0 * s_log, 2.0 * s_log, color=LOG_COLOR, alpha=0.08, label="log's stated +-2 sigma")
        for sgn in (-2.0, 2.0):
            ax.axhline(sgn * s_tw, color=TWIN_COLOR, lw=0.8, ls="--", label="twin's stated +-2 sigma" if sgn > 0 else None)
        ax.plot(x, errs, "o", color=TWIN_COLOR, label="twin's error, per seed")
        ax.axhline(0.0, color="grey", lw=0.5)
        ax.set_xticks(x)
        _label(ax, label, "twin seed", f"alignment error ({unit})", which="major")
    return _finish(fig, axes, title, path, legend_size=7.0)


def plot_twin_shrink(explain: dict, verdict: dict, path=None, title: str = ""):
    """How far each candidate effect shrinks the gap between the log and its twin (the explain step's first round).

    One bar per candidate: the shrink ``1 - G / G_0`` with its sd over the twin's seeds as an error bar, filled where
    the held-out test confirms it (p below the verdict's level), hatched where it does not; the verdict in the title.
    """
    plt = _pyplot(path is not None)
    cands = explain["candidates"]
    fig, ax = plt.subplots(figsize=(8.5, 1.6 + 0.5 * max(len(cands), 1)), constrained_layout=True)
    y = np.arange(len(cands))[::-1]
    for yi, c in zip(y, cands):
        ok = c["p_heldout"] is not None and c["p_heldout"] < 0.01
        c = {**c, "shrink": c["shrink"] or 0.0, "shrink_sd": c["shrink_sd"] or 0.0,
             "p_heldout": 1.0 if c["p_heldout"] is None else c["p_heldout"]}
        ax.barh(yi, c["shrink"], xerr=c["shrink_sd"], color=TWIN_COLOR if ok else "white", edgecolor=TWIN_COLOR,
                hatch=None if ok else "//", capsize=3,
                label=("confirmed on held-out data (p < 0.01)" if ok else "not confirmed held-out"))
        ax.text(max(c["shrink"], 0.0) + c["shrink_sd"] + 0.02, yi, f"{c['shrink']:.2f}  (p = {c['p_heldout']:.1g})",
                va="center", fontsize=8)
    ax.set_yticks(y)
    ax.set_yticklabels([c["label"] for c in cands], fontsize=8)
    ax.set_xlim(min(-0.05, min((c["shrink"] for c in cands), default=0.0) - 0.05), 1.35)
    ax.axvline(0.0, color="grey", lw=0.6)
    ax.axvline(1.0, color="grey", lw=0.6, ls=":")
    ax.set_xlabel("shrink of the gap, 1 - G / G_0\n(G: the findings' log excess over the envelope; sd over seeds)")
    handles, labels = ax.get_legend_handles_labels()
    seen = dict(zip(labels, handles))
    if seen:
        ax.legend(seen.values(), seen.keys(), fontsize=7.5, loc="lower right")
    named = " + ".join(e["effect"] for e in verdict.get("effects", [])) or verdict["effect"]
    status = verdict["status"] + (f": {named}" if verdict["status"] in ("explained", "partly explained") else "")
    ax.set_title(f"{title}\nverdict {status}; G_0 = {explain['gap']:.3g}" if title else f"verdict {status}",
                 fontsize=9.5)
    return finish_figure(fig, path)
