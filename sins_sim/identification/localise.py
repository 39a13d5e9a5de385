"""Noise floor and localisation of the gap (steps 2 and 3 of the diagnosis).

:func:`noise_floor` estimates the floor from the data (the quantisation
``q / sqrt(12)``, or more where the residual's high-frequency band says so);
:func:`localise` finds where a residual exceeds it (the band holding 90 % of
the excess power and its peaks, the time window holding 90 % of the excess
energy, the envelope); :func:`operating_points` cuts an AFC sweep's drive into
its operating points. See :mod:`sins_sim.identification.diagnose`.

.. autosummary::

   noise_floor
   localise
   operating_points
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize, signal

__all__ = ["noise_floor", "localise", "operating_points"]


# --- noise floor ---------------------------------------------------------------------------------
#: Correlation of neighbouring Welch segments for a Hann window at 50 % overlap (Harris 1978, "On the use
#: of windows for harmonic analysis with the discrete Fourier transform", Proc. IEEE 66(1), table 1: 16.7 %).
_HANN_OVERLAP_CORR = 0.167
#: False-alarm level of the test that a PSD bin belongs to the white floor (per bin): a bin above the
#: ``1 - LINE_LEVEL`` quantile of the floor's chi-square law is a coherent line or a resonant peak.
LINE_LEVEL = 1e-3


def _welch_dof(n: int, nper: int) -> float:
    """Equivalent degrees of freedom of a Welch PSD bin: ``2 K / (1 + 2 c^2)`` for ``K`` segments at 50 %
    overlap with the correlation ``c`` of neighbouring segments (Welch 1967, "The use of fast Fourier
    transform for the estimation of power spectra", IEEE Trans. Audio Electroacoust. AU-15, eq. for the
    variance with overlap; Percival & Walden 1993, "Spectral Analysis for Physical Applications",
    sec. 6.17)."""
    k = max(1, 1 + (n - nper) // (nper // 2))
    return 2.0 * k / (1.0 + 2.0 * _HANN_OVERLAP_CORR ** 2)


def noise_floor(residual: np.ndarray, quantum_rad: float, fs_hz: float) -> dict:
    """Noise floor of a residual from the data: quantisation and the high-frequency band.

    The readout quantisation alone gives ``q / sqrt(12)``. White noise of
    any other origin shows in the residual's spectrum where the model has
    nothing to say: the level is the median of the Welch PSD over
    ``[0.55, 0.95] fs/2`` and ``sigma = sqrt(level fs/2)``, taken over the
    bins **free of coherent lines and resonant peaks**: a bin above the
    ``1 - LINE_LEVEL`` quantile of the white floor's law (``level chi2_nu /
    nu`` with the Welch bin's equivalent degrees of freedom ``nu``,
    :func:`_welch_dof`, the level scaled by the median of that law) is left
    out with its two neighbours (the Hann window's leakage), and the
    median is taken again, until no bin is left out (issue 24: a structural
    mode at 1.5-2.5 kHz, whose peak and skirts fill much of the band, was
    read as a noise floor 25 times the quantisation). On white noise the
    test leaves out about one bin in a thousand and the level is that of
    the plain median, divided by the median of ``chi2_nu / nu`` (the median of
    a chi-square law lies below its mean). At least a quarter of the band's bins are kept (the
    lowest, when the spectrum has no flat part).

    Returns
    -------
    dict
        ``floor_rad`` (the larger of the two), ``quantisation_rad``, ``white_rad``, ``excluded_hz``
        (the bands left out as lines or peaks, merged runs of bins ``[f0, f1]``), ``spread`` (the ratio of
        the 90 % and 10 % quantiles of the band's PSD bins) and ``spread_white`` (the same ratio of the
        white floor's chi-square law, ``chi2_nu``: what a white floor gives), ``bin_dof`` (``nu``) and
        ``n_bins`` (the bins the level is the median of: with ``bin_dof`` the estimate's own degrees of
        freedom, :func:`sins_sim.identification.detection.floor_dof`).
    """
    from scipy import stats

    x = np.asarray(residual, dtype=np.float64)
    qn = quantum_rad / math.sqrt(12.0)
    nper = int(min(256, max(16, x.size // 8)))
    f, p = signal.welch(x - x.mean(), fs=fs_hz, nperseg=nper, detrend="linear")
    band = (f >= 0.55 * fs_hz / 2) & (f <= 0.95 * fs_hz / 2)
    excluded = []
    if not np.any(band):
        return {"floor_rad": qn, "quantisation_rad": qn, "white_rad": 0.0, "excluded_hz": excluded, "spread": math.nan,
                "spread_white": math.nan, "bin_dof": math.nan, "n_bins": 0}
    nu = _welch_dof(x.size, min(nper, x.size))
    law = stats.chi2(nu)
    thr = float(law.ppf(1.0 - LINE_LEVEL) / law.median())  # bin / (median of the floor's bins)
    keep = band.copy()
    min_keep = max(1, int(np.ceil(0.25 * np.count_nonzero(band))))
    for _ in range(64):
        level = float(np.median(p[keep]))
        out = band & (p > thr * level)
        out = out | np.r_[out[1:], False] | np.r_[False, out[:-1]]
        new = band & ~out
        if np.count_nonzero(new) < min_keep:
            idx = np.flatnonzero(band)
            new = np.zeros_like(band)
            new[idx[np.argsort(p[idx])[:min_keep]]] = True
        if np.array_equal(new, keep):
            break
        keep = new
    # the median of a white floor's bins is ``level median(chi2_nu) / nu``, a little below the level (by about
    # 2 / (3 nu) relative; Wilson & Hilferty 1931): divided out, so that the floor is unbiased, which the gap's
    # test against it needs (``sins_sim.identification.detection``)
    white = math.sqrt(float(np.median(p[keep])) * nu / float(law.median()) * fs_hz / 2.0)
    # how evenly the band is filled: the ratio of its bins' 90 % and 10 % quantiles, and that of a white
    # floor's chi-square law (a resonance's peak and skirts fill the band unevenly)
    spread = float(np.quantile(p[band], 0.9) / np.quantile(p[band], 0.1)) if np.quantile(p[band], 0.1) > 0 else math.inf
    spread_white = float(law.ppf(0.9) / law.ppf(0.1))
    gone = np.flatnonzero(band & ~keep)
    if gone.size:
        runs = np.split(gone, np.flatnonzero(np.diff(gone) > 1) + 1)
        excluded = [[float(f[r[0]]), float(f[r[-1]])] for r in runs]
    return {"floor_rad": max(qn, white), "quantisation_rad": qn, "white_rad": white, "excluded_hz": excluded,
            "spread": spread, "spread_white": spread_white, "bin_dof": nu, "n_bins": int(np.count_nonzero(keep))}


# --- localisation ------------------------------------------------------------------------------------
def _sine_fit(seg: np.ndarray, fs_hz: float, f_guess: float | None = None):
    """Least-squares ``c cos + s sin`` at a refined frequency: (amplitude, frequency, phase, rms error)."""
    n = seg.size
    t = np.arange(n) / fs_hz
    if f_guess is None:
        spec = np.abs(np.fft.rfft(seg * np.hanning(n), 8 * n))
        f_guess = float(np.fft.rfftfreq(8 * n, 1.0 / fs_hz)[int(np.argmax(spec[1:])) + 1])

    def design(f):
        w = 2.0 * math.pi * f
        return np.column_stack([np.cos(w * t), np.sin(w * t)])

    def res(p):
        d = design(p[0])
        return d @ np.linalg.lstsq(d, seg, rcond=None)[0] - seg

    f = float(optimize.least_squares(res, [f_guess], method="lm", max_nfev=40).x[0])
    c, s = np.linalg.lstsq(design(f), seg, rcond=None)[0]
    err = float(np.sqrt(np.mean(res([f]) ** 2)))
    return float(math.hypot(c, s)), abs(f), float(math.atan2(-s, c)), err


def operating_points(drive: np.ndarray, drive_fs_hz: float, block_s: float = 0.02, rel_tol: float = 0.01,
                     freq_tol_hz: float = 0.05) -> list:
    """Segments of constant drive amplitude and frequency (an AFC sweep's operating points).

    The drive is cut into blocks of ``block_s``; a sine is fitted to each.
    Blocks the sine fits to within 0.1 % of its amplitude (or 3 times the
    median misfit, the drive's own noise) are steady; runs of
    steady blocks that agree within ``rel_tol`` (amplitude) and
    ``freq_tol_hz`` form one point, and a step between two points is placed
    at the sample where the sine of the point after it starts to fit better
    than the sine of the point before it. Returns ``[{"t_s": [t0, t1],
    "v_m": V, "frequency_hz": f}]`` in time order.
    """
    x = np.asarray(drive, dtype=np.float64)
    nb = max(16, int(round(block_s * drive_fs_hz)))
    blocks = []
    for i0 in range(0, x.size - nb + 1, nb):
        amp, f, ph, err = _sine_fit(x[i0:i0 + nb], drive_fs_hz)
        blocks.append((i0, amp, f, err / max(amp, 1e-30)))
    # a block is steady when the sine fits it about as well as it fits most blocks (the drive's own
    # noise), and to 0.1 %: a block holding a step fits much worse
    level = max(1e-3, 3.0 * float(np.median([b[3] for b in blocks]))) if blocks else 1e-3
    blocks = [(i0, amp, f, rel <= level) for i0, amp, f, rel in blocks]
    segs = []  # [first block start, last block end, amplitude, frequency]
    for i0, amp, f, steady in blocks:
        if not steady:
            continue
        if segs and segs[-1][1] == i0 and abs(amp - segs[-1][2]) <= rel_tol * max(segs[-1][2], 1e-30) and \
                abs(f - segs[-1][3]) <= freq_tol_hz:
            segs[-1][1] = i0 + nb
            continue
        if segs and abs(amp - segs[-1][2]) <= rel_tol * max(segs[-1][2], 1e-30) and \
                abs(f - segs[-1][3]) <= freq_tol_hz:
            segs[-1][1] = i0 + nb  # the same point on both sides of an unsteady block
            continue
        segs.append([i0, i0 + nb, amp, f])
    if not segs:
        return []
    # refine each point's sine on its whole steady span, then place the steps between points
    fits = []
    for s0, s1, amp, f in segs:
        a, fr, ph, _ = _sine_fit(x[s0:s1], drive_fs_hz, f)
        fits.append((s0, s1, a, fr, ph))
    bounds = [0]
    for (a0, a1, amp_a, f_a, ph_a), (b0, b1, amp_b, f_b, ph_b) in zip(fits[:-1], fits[1:]):
        k = np.arange(a1, b0)
        if k.size == 0:
            bounds.append(b0)
            continue
        ya = amp_a * np.cos(2.0 * math.pi * f_a * (k - a0) / drive_fs_hz + ph_a)
        yb = amp_b * np.cos(2.0 * math.pi * f_b * (k - b0) / drive_fs_hz + ph_b)
        ea = np.concatenate(([0.0], np.cumsum((x[k] - ya) ** 2)))
        eb = np.concatenate((np.cumsum(((x[k] - yb) ** 2)[::-1])[::-1], [0.0]))
        bounds.append(int(a1 + np.argmin(ea + eb)))
    bounds.append(x.size)
    return [{"t_s": [bounds[i] / drive_fs_hz, bounds[i + 1] / drive_fs_hz], "v_m": fits[i][2],
             "frequency_hz": fits[i][3]} for i in range(len(fits))]


def _quantile_span(x: np.ndarray, w: np.ndarray, lo: float = 0.05, hi: float = 0.95):
    w = np.clip(w, 0.0, None)
    if w.sum() <= 0:
        return None
    c = np.cumsum(w) / w.sum()
    return [float(x[int(np.searchsorted(c, lo))]), float(x[min(int(np.searchsorted(c, hi)), x.size - 1)])]


def localise(residual: np.ndarray, floor_rad: float, fs_hz: float, window_s: float | None = None) -> dict:
    """Where a residual exceeds its floor: spectrum band, peaks, time window, envelope.

    Parameters
    ----------
    residual : ndarray
        Measured minus model (rad); NaN samples (left out) are skipped.
    floor_rad : float
        The white noise floor (rad RMS).

    Returns
    -------
    dict
        ``band_hz`` [lo, hi] holding 90 % of the excess power (or None),
        ``peaks_hz`` (up to 3 strongest excess peaks), ``time_s`` [t0, t1]
        holding 90 % of the excess energy (or None), ``envelope`` (``t``,
        ``rms``), ``spectrum`` (``f``, ``psd``, ``floor_psd``).
    """
    r = np.asarray(residual, dtype=np.float64)
    t = np.arange(r.size) / fs_hz
    ok = np.isfinite(r)
    i0 = int(np.argmax(ok))
    rr = r[i0:][np.isfinite(r[i0:])] if ok.any() else np.zeros(8)
    nper = int(min(rr.size, max(64, min(4096, int(0.5 * fs_hz)))))
    f, p = signal.welch(rr, fs=fs_hz, nperseg=nper, detrend="constant")
    floor_psd = floor_rad ** 2 / (fs_hz / 2.0)
    excess = np.clip(p - floor_psd, 0.0, None) * (p > 2.0 * floor_psd)
    band = _quantile_span(f, excess)
    peaks = []
    if excess.any():
        idx, _ = signal.find_peaks(excess)
        if excess[0] > 0 and (excess.size < 2 or excess[0] >= excess[1]):
            idx = np.concatenate(([0], idx))
        idx = idx[np.argsort(excess[idx])[::-1]][:3]
        peaks = [float(f[i]) for i in idx]
    if window_s is None:
        window_s = min(0.05, max(r.size / fs_hz / 40.0, 8.0 / fs_hz))
    nw = max(4, int(round(window_s * fs_hz)))
    env_t, env = [], []
    for j in range(0, r.size - nw + 1, nw):
        seg = r[j:j + nw]
        seg = seg[np.isfinite(seg)]
        if seg.size:
            env_t.append((j + 0.5 * nw) / fs_hz)
            env.append(float(np.sqrt(np.mean(seg * seg))))
    env_t = np.array(env_t)
    env = np.array(env)
    ex_t = np.clip(env ** 2 - floor_rad ** 2, 0.0, None) * (env > 1.2 * floor_rad)
    span = _quantile_span(env_t, ex_t)
    if span is not None:
        span = [max(0.0, span[0] - 0.5 * window_s), min(t[-1], span[1] + 0.5 * window_s)]
    return {"band_hz": band, "peaks_hz": peaks, "time_s": span, "envelope": {"t": env_t, "rms": env},
            "spectrum": {"f": f, "psd": p, "floor_psd": floor_psd}}
