"""Figures of a GNSS-aided run (issue 37): errors inside the filter's 3-sigma, biases converging, outage growth,
innovations.

Every function takes the records of :mod:`sins_sim.navigation.aided` (SI units, rad) and converts at the edge:
position in m, velocity in m/s, attitude in arcsec or arcmin (whichever reads better, per panel), gyro biases in
deg/h, accelerometer biases in ug. The error-state layout (which column of ``sigma`` is which) is read from
:mod:`sins_sim.navigation.ekf`, the one place it is written. GNSS outages are shaded grey, the legend naming
their windows.

A long record is drawn through a min/max decimation (:func:`minmax_decimate`): each of at most
:data:`MAX_BINS` time bins contributes its smallest and its largest value in time order, so a peak
between two drawn points is never lost (no aliasing), and a 3-sigma envelope is drawn through the
largest sigma of each bin (it never narrows by decimation).

Each figure is returned; given ``path`` it is written there and closed (:func:`~sins_sim.plots.common.finish_figure`).

.. autosummary::

   aided_error_figure
   bias_figure
   outage_growth_figure
   innovation_figure
   minmax_decimate
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from sins_sim.navigation import ekf
from sins_sim.navigation.aided import AidedResult, OutageGrowth, SmoothedResult
from sins_sim.plots.common import _pyplot, finish_figure
from sins_sim.units import ARCMIN, ARCSEC, DEG_PER_H, MICRO_G

__all__ = ["aided_error_figure", "bias_figure", "outage_growth_figure", "innovation_figure", "minmax_decimate",
           "MAX_BINS", "OUTAGE_COLOR"]

#: Most time bins a series is drawn with; a longer one goes through :func:`minmax_decimate` (2 points a bin).
MAX_BINS = 2000
#: Shading of a GNSS outage: mid grey, light enough for the curves in front to stay readable.
OUTAGE_COLOR = "#888888"
_OUTAGE_ALPHA = 0.22
#: One colour per axis, north/x, east/y, down/z (Okabe & Ito 2008, colour-blind safe).
AXIS_COLORS = ("#0072B2", "#D55E00", "#009E73")
_NED = ("north", "east", "down")
_XYZ = ("x", "y", "z")
#: Above this magnitude an attitude panel is drawn in arcmin instead of arcsec.
_ARCMIN_ABOVE_ARCSEC = 600.0


# --- checks and conversions ---------------------------------------------------------------------------------


def _check_series(result, name="result"):
    if not isinstance(result, (AidedResult, SmoothedResult)):
        raise ValueError(f"{name}: must be an AidedResult or a SmoothedResult (navigate_aided, smooth), "
                         f"got {type(result).__name__}")
    return result


def _check_outages(outages_s) -> list:
    """``[(start, end), ...]`` with finite ``start < end`` (s)."""
    try:
        items = list(outages_s)
    except TypeError:
        raise ValueError(f"outages_s: must be a sequence of (start, end) pairs (s), got {outages_s!r}") from None
    out = []
    for i, w in enumerate(items):
        pair = np.asarray(w, dtype=np.float64) if np.ndim(w) == 1 else np.zeros(0)
        if pair.shape != (2,) or not np.all(np.isfinite(pair)) or not pair[0] < pair[1]:
            raise ValueError(f"outages_s[{i}]: must be a (start, end) pair of finite times with start < end (s), "
                             f"got {w!r}")
        out.append((float(pair[0]), float(pair[1])))
    return out


def _check_table(name, value, k, ncol, *, allow_row=False):
    """A finite ``(k, ncol)`` array (or one ``(ncol,)`` row broadcast to it, with ``allow_row``)."""
    arr = np.asarray(value, dtype=np.float64)
    shapes = [(k, ncol)] + ([(ncol,)] if allow_row else [])
    if arr.shape not in shapes or not np.all(np.isfinite(arr)):
        want = " or ".join(str(s) for s in shapes)
        raise ValueError(f"{name}: must be a finite array of shape {want} (one row per epoch of result.t_s), "
                         f"got shape {arr.shape}")
    return np.broadcast_to(arr, (k, ncol))


def _angle_unit(values_rad):
    """``(scale_rad, "arcsec" | "arcmin")`` for the largest finite magnitude of ``values_rad``."""
    a = np.abs(np.asarray(values_rad, dtype=np.float64))
    peak = float(np.max(a[np.isfinite(a)], initial=0.0))
    return (ARCMIN, "arcmin") if peak / ARCSEC > _ARCMIN_ABOVE_ARCSEC else (ARCSEC, "arcsec")


def _time_axis(t_s):
    """``(scale_s, label)``: seconds, or minutes for a record longer than 20 min."""
    t = np.asarray(t_s, dtype=np.float64)
    span = float(t[-1] - t[0]) if t.size else 0.0
    return (60.0, "time (min)") if span > 1200.0 else (1.0, "time (s)")


def minmax_decimate(t, y, max_bins: int = MAX_BINS):
    """A series reduced to the smallest and largest value of each of ``max_bins`` equal time bins.

    The two points of a bin are kept in their time order, so the polyline through them runs through every
    peak of the original (no aliasing; the classic min/max decimation of an oscilloscope). A series with at
    most ``2 max_bins`` points is returned unchanged. NaN values are ignored (a bin of NaN only is dropped).

    Parameters
    ----------
    t : array_like, shape (K,)
        Increasing times.
    y : array_like, shape (K,)
        The values.
    max_bins : int
        Number of bins, >= 1.

    Returns
    -------
    t_d, y_d : ndarray
        The kept points (at most ``2 max_bins``), a subset of the input pairs.
    """
    t = np.asarray(t, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if t.ndim != 1 or y.shape != t.shape:
        raise ValueError(f"y: must have the shape of t {t.shape}, got {y.shape}")
    if isinstance(max_bins, bool) or not isinstance(max_bins, (int, np.integer)) or max_bins < 1:
        raise ValueError(f"max_bins: must be an integer >= 1, got {max_bins!r}")
    if t.size <= 2 * max_bins:
        return t, y
    edges = np.linspace(t[0], t[-1], max_bins + 1)
    b = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, max_bins - 1)
    keep = np.zeros(t.size, dtype=bool)
    starts = np.flatnonzero(np.r_[True, b[1:] != b[:-1]])
    for lo, hi in zip(starts, np.r_[starts[1:], t.size]):
        seg = y[lo:hi]
        if np.all(np.isnan(seg)):
            continue
        keep[lo + np.nanargmin(seg)] = True
        keep[lo + np.nanargmax(seg)] = True
    return t[keep], y[keep]


def _bin_max(t, y, max_bins: int = MAX_BINS):
    """The largest value of each time bin at the bin's time of that value (an envelope that never narrows)."""
    t = np.asarray(t, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if t.size <= 2 * max_bins:
        return t, y
    edges = np.linspace(t[0], t[-1], max_bins + 1)
    b = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, max_bins - 1)
    starts = np.flatnonzero(np.r_[True, b[1:] != b[:-1]])
    idx = [lo + int(np.argmax(y[lo:hi])) for lo, hi in zip(starts, np.r_[starts[1:], t.size])]
    return t[idx], y[idx]


def _outage_label(outages) -> str:
    """``GNSS outage 240-360 s`` (or ``GNSS outages 240-360, 500-560 s``): the legend entry names the windows."""
    spans = ", ".join(f"{a:g}-{b:g}" for a, b in outages)
    return f"GNSS outage{'s' if len(outages) > 1 else ''} {spans} s"


def _shade_outages(ax, outages, scale):
    """Grey spans over the outages, behind everything; the first carries the legend label naming the windows."""
    for i, (a, b) in enumerate(outages):
        ax.axvspan(a / scale, b / scale, color=OUTAGE_COLOR, alpha=_OUTAGE_ALPHA, lw=0, zorder=0,
                   label=_outage_label(outages) if i == 0 else None, gid=f"outage_{i}")


def _outage_handle(outages):
    from matplotlib.patches import Patch

    return Patch(facecolor=OUTAGE_COLOR, alpha=_OUTAGE_ALPHA, label=_outage_label(outages))


def _band(ax, t, center, half, color, gid, label=None):
    """``center +- half`` as a light fill with thin dashed edges, behind the lines (``gid`` on the upper edge)."""
    tt, hi = _bin_max(t, half)
    c = np.interp(tt, t, center) if np.ndim(center) else np.full(tt.shape, float(center))
    ax.fill_between(tt, c - hi, c + hi, color=color, alpha=0.16, lw=0, zorder=1, label=label)
    ax.plot(tt, c + hi, color=color, lw=0.7, ls=(0, (3, 2)), alpha=0.8, zorder=2, gid=f"{gid}_upper")
    ax.plot(tt, c - hi, color=color, lw=0.7, ls=(0, (3, 2)), alpha=0.8, zorder=2, gid=f"{gid}_lower")


def _grid(res, nrows: int, height: float, path):
    """A ``nrows`` x 3 grid of panels sharing the time axis of ``res`` (labelled on the bottom row):
    ``(fig, axes, time scale in s)``."""
    plt = _pyplot(path is not None)
    scale_t, t_label = _time_axis(res.t_s)
    fig, axes = plt.subplots(nrows, 3, figsize=(13.0, height), sharex=True, layout="constrained")
    for ax in axes[-1]:
        ax.set_xlabel(t_label)
    return fig, axes, scale_t


def _finish_grid(fig, handles, outages, head: str, path):
    """One legend under the grid (with the outages' entry), the title, and :func:`finish_figure`."""
    if outages:
        handles.append(_outage_handle(outages))
    fig.legend(handles=handles, loc="outside lower center", ncol=len(handles), fontsize=9, frameon=False)
    fig.suptitle(head, fontsize=11)
    return finish_figure(fig, path)


# --- error against the filter's 3-sigma ------------------------------------------------------------------------


def aided_error_figure(result, truth_errors=None, outages_s=(), title: str = "", *, path=None):
    """Position, velocity and attitude errors north, east, down against time inside the filter's +-3-sigma.

    Three rows (position m, velocity m/s, attitude psi in arcsec or arcmin) by three columns (north, east,
    down). The +-3-sigma envelope (``3 result.sigma`` of the state, converted) is a light band with dashed
    edges behind the error, which is drawn on top; each panel states the share of epochs whose error lies
    inside it. GNSS outages are shaded grey, the legend naming their windows.with their window.

    Parameters
    ----------
    result : AidedResult or SmoothedResult
        The run (:func:`~sins_sim.navigation.aided.navigate_aided`, :func:`~sins_sim.navigation.aided.smooth`).
    truth_errors : array_like, shape (K, 9), optional
        Errors at ``result.t_s``: ``[dN, dE, dD (m), dvN, dvE, dvD (m/s), psiN, psiE, psiD (rad)]``, computed
        minus true, as :meth:`AidedResult.errors` returns them. Without it only the envelopes are drawn and the
        title says so.
    outages_s : sequence of (start, end)
        GNSS outage windows (s), shaded.
    title : str
        Figure title.
    path : str or Path, optional
        Write the figure there and close it.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        For a bad argument (the message names it).
    """
    res = _check_series(result)
    k = len(res)
    err = None if truth_errors is None else _check_table("truth_errors", truth_errors, k, 9)
    outages = _check_outages(outages_s)
    fig, axes, scale_t = _grid(res, 3, 8.6, path)
    t = res.t_s / scale_t
    rows = (("position", ekf.POS, "m"), ("velocity", ekf.VEL, "m/s"), ("attitude ψ", ekf.ATT, None))
    for r, (quantity, block, unit) in enumerate(rows):
        for c in range(3):
            ax = axes[r, c]
            col = block.start + c
            sig3 = 3.0 * res.sigma[:, col]
            e = None if err is None else err[:, col]
            if unit is None:
                scale, u = _angle_unit(sig3 if e is None else np.concatenate([sig3, e]))
            else:
                scale, u = 1.0, unit
            color = AXIS_COLORS[c]
            _shade_outages(ax, outages, scale_t)
            _band(ax, t, 0.0, sig3 / scale, color, gid=f"sigma3_{ekf.STATE_NAMES[col]}")
            if e is not None:
                td, ed = minmax_decimate(t, e / scale)
                ax.plot(td, ed, color=color, lw=1.0, zorder=4, gid=f"error_{ekf.STATE_NAMES[col]}")
                inside = float(np.mean(np.abs(e) <= sig3))
                ax.set_title(f"inside ±3-sigma at {100.0 * inside:.1f} % of {k} epochs", fontsize=8, color="0.25")
            ax.axhline(0.0, color="k", lw=0.4, zorder=3)
            ax.set_ylabel(f"{quantity} {_NED[c]} ({u})", fontsize=9)
            ax.grid(True, alpha=0.3)
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [Patch(facecolor="0.5", alpha=0.3, edgecolor="0.3", ls="--", label="filter's ±3-sigma")]
    if err is not None:
        handles.insert(0, Line2D([], [], color="0.2", lw=1.0, label="error (computed - true)"))
    kind = type(res).__name__.replace("Result", "")
    head = title or f"{kind} solution: error north, east, down and the filter's ±3-sigma"
    if err is None:
        head += "\n(no truth given: the filter's ±3-sigma envelope only)"
    return _finish_grid(fig, handles, outages, head, path)


# --- bias estimates -------------------------------------------------------------------------------------------


def bias_figure(result, true_gyro_bias_rad_s=None, true_accel_bias_m_s2=None, *, outages_s=(), path=None):
    """The gyro (deg/h) and accelerometer (ug) bias estimates per body axis converging, with +-3-sigma and the truth.

    Two rows (gyro, accelerometer) by three columns (x, y, z). The estimate is the line; the band around it is
    +-3 sigma of the estimate's error (the bias states of ``result.sigma``), so a consistent filter keeps the
    true value (black dashed) inside the band.

    Parameters
    ----------
    result : AidedResult or SmoothedResult
        The run.
    true_gyro_bias_rad_s : array_like, shape (3,) or (K, 3), optional
        The true gyro biases (rad/s, body x, y, z): constant, or one row per epoch of ``result.t_s``.
    true_accel_bias_m_s2 : array_like, shape (3,) or (K, 3), optional
        The true accelerometer biases (m/s^2).
    outages_s : sequence of (start, end)
        GNSS outage windows (s), shaded.
    path : str or Path, optional
        Write the figure there and close it.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        For a bad argument (the message names it).
    """
    res = _check_series(result)
    k = len(res)
    truths = [None if val is None else _check_table(name, val, k, 3, allow_row=True)
              for name, val in (("true_gyro_bias_rad_s", true_gyro_bias_rad_s),
                                ("true_accel_bias_m_s2", true_accel_bias_m_s2))]
    outages = _check_outages(outages_s)
    fig, axes, scale_t = _grid(res, 2, 6.4, path)
    t = res.t_s / scale_t
    rows = (("gyro bias", res.gyro_bias_rad_s, ekf.GYRO_BIAS, DEG_PER_H, "deg/h"),
            ("accel bias", res.accel_bias_m_s2, ekf.ACCEL_BIAS, MICRO_G, "ug"))
    for r, (quantity, est, block, scale, unit) in enumerate(rows):
        for c in range(3):
            ax = axes[r, c]
            col = block.start + c
            color = AXIS_COLORS[c]
            _shade_outages(ax, outages, scale_t)
            _band(ax, t, est[:, c] / scale, 3.0 * res.sigma[:, col] / scale, color,
                  gid=f"sigma3_{ekf.STATE_NAMES[col]}")
            td, ed = minmax_decimate(t, est[:, c] / scale)
            ax.plot(td, ed, color=color, lw=1.2, zorder=4, gid=f"estimate_{quantity.split()[0]}_{_XYZ[c]}")
            truth = truths[r]
            if truth is not None:
                if np.all(truth[:, c] == truth[0, c]):
                    ax.axhline(truth[0, c] / scale, color="k", lw=1.1, ls="--", zorder=5,
                               gid=f"true_{quantity.split()[0]}_{_XYZ[c]}")
                    final = f"true {truth[0, c] / scale:.3g}, "
                else:
                    ax.plot(t, truth[:, c] / scale, color="k", lw=1.1, ls="--", zorder=5,
                            gid=f"true_{quantity.split()[0]}_{_XYZ[c]}")
                    final = ""
            else:
                final = ""
            ax.set_title(f"{final}final {est[-1, c] / scale:.3g} ± {res.sigma[-1, col] / scale:.2g} (1-sigma) {unit}",
                         fontsize=8, color="0.25")
            ax.set_ylabel(f"{quantity} body {_XYZ[c]} ({unit})", fontsize=9)
            ax.grid(True, alpha=0.3)
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [Line2D([], [], color="0.2", lw=1.2, label="estimate"),
               Patch(facecolor="0.5", alpha=0.3, edgecolor="0.3", ls="--", label="estimate ±3-sigma")]
    if any(x is not None for x in truths):
        handles.append(Line2D([], [], color="k", lw=1.1, ls="--", label="true bias"))
    head = "Sensor bias estimates converging, with the filter's ±3-sigma"
    if all(x is None for x in truths):
        head += "\n(no true biases given)"
    return _finish_grid(fig, handles, outages, head, path)


# --- outage growth --------------------------------------------------------------------------------------------


def outage_growth_figure(growths, *, result=None, path=None):
    """Horizontal position error in each GNSS outage against time into it: measured against predicted.

    One column per outage. Top: markers, the horizontal error of the solution at the read times
    (:attr:`OutageGrowth.error_m`); lines, the filter's predicted 1-sigma and 3-sigma, ``sqrt(P_NN + P_EE)``
    propagated from the last update with no measurement. With ``result`` (the run the growths were read from)
    the prediction is drawn at every epoch of the outage; without, it is joined between the read times and
    marked there. Bottom: the measured error in units of the predicted 1-sigma, against 1 and 3 (one run's
    horizontal error is Rayleigh-like: below 1 sigma about half the time, rarely beyond 3).

    Parameters
    ----------
    growths : sequence of OutageGrowth
        :func:`~sins_sim.navigation.aided.outage_growth` of one run.
    result : AidedResult, optional
        The run, for the prediction between the read times.
    path : str or Path, optional
        Write the figure there and close it.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        For a bad argument (the message names it).
    """
    try:
        gs = list(growths)
    except TypeError:
        raise ValueError(f"growths: must be a sequence of OutageGrowth, got {type(growths).__name__}") from None
    if not gs:
        raise ValueError("growths: must hold at least one OutageGrowth (outage_growth of a run with outages)")
    for i, g in enumerate(gs):
        if not isinstance(g, OutageGrowth):
            raise ValueError(f"growths[{i}]: must be an OutageGrowth, got {type(g).__name__}")
    if result is not None and not isinstance(result, AidedResult):
        raise ValueError(f"result: must be the AidedResult the growths were read from, got {type(result).__name__}")
    plt = _pyplot(path is not None)
    ncol = min(len(gs), 3)
    nrow = math.ceil(len(gs) / ncol)
    measured = [np.isfinite(g.t_s) & np.isfinite(g.error_m) for g in gs]
    with_ratio = any(np.any(m) for m in measured)
    per = 2 if with_ratio else 1
    height = (5.0 if with_ratio else 4.0) * nrow + 0.7
    fig, axes = plt.subplots(per * nrow, ncol, figsize=(max(6.4, 4.8 * ncol), height),
                             squeeze=False, layout="constrained",
                             gridspec_kw={"height_ratios": ([3, 1] if with_ratio else [1]) * nrow})
    for i, g in enumerate(gs):
        ax = axes[per * (i // ncol), i % ncol]
        have = np.isfinite(g.t_s)
        tau = g.after_s
        if result is not None:
            ta = g.t_last_update_s
            later = np.flatnonzero(result.updated & (result.t_s > ta))
            t_next = float(result.t_s[later[0]]) if later.size else math.inf
            sel = (result.t_s >= ta) & (result.t_s < t_next)
            # result.sigma is after each epoch's update: at t_a the updated covariance, later (no update in
            # between) the propagated one; a mission's kept result carries sigma but not the 15x15 matrices
            x_line = result.t_s[sel] - ta
            sig_line = np.hypot(result.sigma[sel, 0], result.sigma[sel, 1])
        else:
            x_line, sig_line = tau[have], g.predicted_sigma_m[have]
        mark = {} if result is not None else {"marker": "_", "ms": 9}
        ax.plot(x_line, sig_line, color="#0072B2", lw=1.5, label="predicted 1-sigma", gid="predicted_1sigma", **mark)
        ax.plot(x_line, 3.0 * sig_line, color="#0072B2", lw=1.2, ls="--", label="predicted 3-sigma",
                gid="predicted_3sigma", **mark)
        ok = measured[i]
        if np.any(ok):
            ax.plot(tau[ok], g.error_m[ok], ls="none", marker="o", ms=6, mfc="#D55E00", mec="k", mew=0.6, zorder=5,
                    label="measured error", gid="measured")
        if np.any(~have):
            ax.text(0.02, 0.55, "not read at " + ", ".join(f"{x:g}" for x in tau[~have]) + " s\n(outage over or no "
                    "epoch there)", transform=ax.transAxes, fontsize=7, color="0.3")
        a, b = g.window_s
        ax.set_title(f"outage {a:g}-{b:g} s (last update at {g.t_last_update_s:g} s)", fontsize=9)
        ax.set_ylabel("horizontal position error (m)")
        ax.set_xlim(0.0, max(float(np.max(tau)), float(np.max(x_line, initial=0.0))) * 1.03)
        ax.set_ylim(0.0, None)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="upper left")
        bottom = ax
        if with_ratio:
            ax_r = axes[per * (i // ncol) + 1, i % ncol]
            ax_r.sharex(ax)
            ax.tick_params(labelbottom=False)
            ratio = g.error_m[ok] / g.predicted_sigma_m[ok]
            ax_r.plot(tau[ok], ratio, ls="none", marker="o", ms=5, mfc="#D55E00", mec="k", mew=0.6, gid="ratio")
            for level, style in ((1.0, "-"), (3.0, "--")):
                ax_r.axhline(level, color="#0072B2", lw=1.0, ls=style)
            ax_r.set_ylim(0.0, max(3.5, float(np.max(ratio, initial=0.0)) * 1.1))
            ax_r.set_ylabel("error / 1-sigma (1)", fontsize=9)
            ax_r.grid(True, alpha=0.3)
            bottom = ax_r
        bottom.set_xlabel("time since the last GNSS update (s)")
    for k in range(len(gs), nrow * ncol):
        for r in range(per):
            axes[per * (k // ncol) + r, k % ncol].set_visible(False)
    head = "Horizontal error growth in GNSS outages:\nmeasured against the filter's prediction"
    if not with_ratio:
        head += " (no truth given: the prediction only)"
    fig.suptitle(head, fontsize=11)
    return finish_figure(fig, path)


# --- innovations ----------------------------------------------------------------------------------------------


def _window_means(t, x, window):
    """Means of ``x`` over consecutive windows of ``window`` samples inside each uninterrupted stretch (a gap is a
    step in ``t`` over 3 times the median step; the incomplete window at a stretch's end is left out), at the windows'
    mean times, with NaN between stretches so no line joins them across a gap."""
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    if t.size < 2:
        return np.zeros(0), np.zeros(0)
    dt = np.diff(t)
    step = float(np.median(dt))
    cuts = np.r_[0, np.flatnonzero(dt > 3.0 * step) + 1, t.size]
    tm, m = [], []
    for lo, hi in itertools.pairwise(cuts):
        n = (hi - lo) // window
        if n == 0:
            continue
        if tm:
            tm.append(np.array([np.nan]))
            m.append(np.array([np.nan]))
        tm.append(t[lo:lo + n * window].reshape(n, window).mean(axis=1))
        m.append(x[lo:lo + n * window].reshape(n, window).mean(axis=1))
    return (np.concatenate(tm), np.concatenate(m)) if tm else (np.zeros(0), np.zeros(0))



def innovation_figure(result, window: int = 25, *, outages_s=(), path=None):
    """Normalised innovations of each GNSS measurement with +-3 bounds, and the NIS mean with its chi-square bounds.

    One row per measurement (``position``, ``velocity``): ``nu_i / sqrt(S_ii)`` north, east, down against the
    time of application, between the +-3 lines a consistent filter stays inside 99.7 % of the time. Last row:
    the NIS averaged over consecutive windows of ``window`` fixes, with the two-sided 95 % interval of such a
    mean, ``chi2.ppf([0.025, 0.975], m n) / n`` for ``n`` fixes of ``m = 3`` degrees of freedom (Bar-Shalom,
    Li & Kirubarajan 2001, sec. 5.4), and the mean over the whole run in the legend with its ``n``.

    Parameters
    ----------
    result : AidedResult
        The run.
    window : int
        Fixes per NIS mean, >= 1.
    outages_s : sequence of (start, end)
        GNSS outage windows (s), shaded.
    path : str or Path, optional
        Write the figure there and close it.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        For a bad argument (the message names it), or a run without innovations.
    """
    from scipy.stats import chi2

    if not isinstance(result, AidedResult):
        raise ValueError(f"result: must be an AidedResult (navigate_aided), got {type(result).__name__}")
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 1:
        raise ValueError(f"window: must be an integer >= 1 (fixes per NIS mean), got {window!r}")
    outages = _check_outages(outages_s)
    names = [n for n in ("position", "velocity", *sorted(set(result.innovation_name) - {"position", "velocity"}))
             if np.any(result.innovation_name == n)]
    if not names:
        raise ValueError("result: holds no innovations (no fix was applied)")
    plt = _pyplot(path is not None)
    scale_t, t_label = _time_axis(result.t_s)
    fig, axes = plt.subplots(len(names) + 1, 1, figsize=(11.0, 2.7 * (len(names) + 1) + 0.6), sharex=True,
                             layout="constrained")
    side = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "fontsize": 8, "borderaxespad": 0.0}
    for ax, name in zip(axes, names):
        sel = result.innovation_name == name
        t = result.innovation_t_s[sel] / scale_t
        z = result.innovation[sel] / result.innovation_sigma[sel]
        _shade_outages(ax, outages, scale_t)
        for c in range(3):
            td, zd = minmax_decimate(t, z[:, c])
            ax.plot(td, zd, ls="none", marker=".", ms=2.0, color=AXIS_COLORS[c], alpha=0.7, rasterized=True,
                    label=f"{_NED[c]}: RMS {np.sqrt(np.mean(z[:, c] ** 2)):.2f},\n"
                          f"{100.0 * np.mean(np.abs(z[:, c]) > 3.0):.1f} % beyond ±3", gid=f"nu_{name}_{c}")
        for sgn in (-3.0, 3.0):
            ax.axhline(sgn, color="k", lw=0.9, ls="--", zorder=5, label="±3 (99.7 %)" if sgn > 0 else None)
        ax.axhline(0.0, color="k", lw=0.4)
        ax.set_ylabel(f"normalised {name}\ninnovation (1)", fontsize=9)
        ax.set_title(f"{name}: nu / sqrt(S) per axis, {int(sel.sum())} fixes", fontsize=9)
        ax.legend(markerscale=4, **side)
        ax.grid(True, alpha=0.3)
    ax = axes[-1]
    _shade_outages(ax, outages, scale_t)
    dof = 3
    lo, hi = chi2.ppf([0.025, 0.975], dof * window) / window
    for j, name in enumerate(names):
        sel = result.innovation_name == name
        tm, m = _window_means(result.innovation_t_s[sel], result.nis[sel], window)
        nis = result.nis[sel]
        ax.plot(tm / scale_t, m, marker="o", ms=3, lw=0.9, color=("#CC79A7", "#E69F00", "#56B4E9")[j % 3],
                label=f"{name}: mean NIS {nis.mean():.2f}\nover n = {nis.size} (expected {dof})", gid=f"nis_{name}")
    ax.axhspan(lo, hi, color="#009E73", alpha=0.14, lw=0, zorder=0,
               label=f"95 % interval of a\n{window}-fix mean: {lo:.2f}-{hi:.2f}")
    ax.axhline(dof, color="k", lw=0.6, ls=":")
    ax.set_ylabel(f"NIS, mean of\n{window} fixes (1)", fontsize=9)
    ax.set_title(f"NIS averaged over {window} consecutive fixes (within uninterrupted stretches of fixes)", fontsize=9)
    ax.set_xlabel(t_label)
    ax.legend(**side)
    ax.grid(True, alpha=0.3)
    fig.suptitle("GNSS innovations: normalised by the filter's predicted sigma, and the NIS against chi-square",
                 fontsize=11)
    return finish_figure(fig, path)
