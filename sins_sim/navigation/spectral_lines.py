"""Power spectral density of a sensor record and the spectral lines standing out of its noise floor.

Arrays in, numbers out (SI: a gyro's rate in rad/s, an accelerometer's specific force in m/s^2).

.. autosummary::

   welch_edf
   welch_psd
   find_lines
   Psd
   SpectralLine
   LineSearch

Method:

1. **PSD**: Welch's averaged, modified periodogram (Welch 1967; Percival and Walden 1993, sec. 6.17;
   ``scipy.signal.welch``), one-sided density (unit^2/Hz), Hann window, 50 % overlap, each segment's mean
   removed. By default ``nperseg = n // 8`` (15 segments): a resolution ``fs / nperseg`` of 8 / T.
2. **Degrees of freedom**: a Welch estimate of a smooth spectrum ``S`` is distributed as ``S chi2(nu) / nu``
   with the equivalent degrees of freedom of the window and overlap (Percival and Walden 1993, eq. 292b)::

       nu = 2 N_B / (1 + 2 sum_{m=1}^{N_B-1} (1 - m / N_B) |sum_t h_t h_{t+m N_S}|^2),   sum_t h_t^2 = 1

   (``N_B`` segments shifted by ``N_S`` samples): about ``1.89 N_B`` for Hann at 50 % overlap.
3. **Local noise floor** at bin ``k``: the median of the ``2 (half_window - guard)`` bins at distances
   ``guard + 1 .. half_window`` on both sides (the guard keeps the line's own main lobe, +-2 bins for Hann, out),
   divided by the median of ``chi2(nu) / nu`` (the median of a chi-square is below its mean). A sample median of
   ``m`` values has about ``2 / pi`` of the mean's efficiency, and adjacent Hann bins are correlated, so the floor
   is taken as ``S chi2(nu_f) / nu_f`` with ``nu_f = nu (m / 2) (2 / pi)`` (half the neighbours independent).
4. **Detection**: the ratio of a bin to its floor is then ``F(nu, nu_f)`` distributed; a line is declared where
   it exceeds the ``1 - p`` quantile, ``p = false_alarm / bins searched`` (Bonferroni: the chance of one or more
   false lines in the record is at most ``false_alarm`` whatever the bins' correlation). Searched: the bins whose
   whole window lies inside the spectrum, ``half_window + 1 .. n_bins - 1 - half_window``.
5. **A line**: the highest bin above the threshold, then the next highest more than ``2 guard`` bins away, ...;
   a candidate within ``half_window`` bins of a stronger line whose excess is below the Hann window's highest
   sidelobe (-31.5 dB, Harris 1978, Table 1) of that line's is the stronger line's leakage and is dropped.
   Its power is the excess over the floor summed over the ``+-guard`` bins around its peak: for a sinusoid
   ``A sin(2 pi f t)`` that sum times the bin width is ``A^2 / 2`` (Parseval with the density scaling; the Hann
   main lobe holds > 99.9 % of the power at +-3 bins), so ``A = sqrt(2 df sum(P_k - floor_k))``; the frequency is the
   excess-weighted mean of those bins (uncertain to about a bin, ``fs / nperseg``).
6. **Amplitude's sigma**: a bin holding a line of power ``s`` over noise ``S`` has variance
   ``(2 / nu) (S^2 + 2 s S)`` (the noise's own and its cross term with the line: a complex Gaussian bin of variance
   ``S`` plus a fixed ``sqrt(s)``); the bins are summed as fully correlated (an upper bound, Minkowski), and the
   floor's own uncertainty ``sqrt(2 / nu_f)`` over the bins is added in quadrature.
7. **Increments**: a record of increments divided by their interval ``dt`` sees an input line through the
   interval's average, a gain ``sinc(f dt)``; ``find_lines(..., increment_dt=dt)`` divides it out, so the
   amplitude is the input's (rate or specific force). A line above the Nyquist frequency appears folded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["HANN_SIDELOBE", "LineSearch", "Psd", "SpectralLine", "find_lines", "welch_edf", "welch_psd"]

#: Highest sidelobe of the Hann window as a power ratio, -31.5 dB (Harris 1978, Table 1).
HANN_SIDELOBE = 10.0 ** (-31.5 / 10.0)
#: Segments by default: ``nperseg = n // DEFAULT_SEGMENTS`` (15 segments at 50 % overlap).
DEFAULT_SEGMENTS = 8
#: Fewest samples in a segment.
MIN_NPERSEG = 64


@dataclass(frozen=True)
class Psd:
    """A Welch PSD.

    Attributes
    ----------
    freq_hz : ndarray
        Bin frequencies (Hz), from 0 to the Nyquist frequency.
    psd : ndarray
        One-sided density (unit^2/Hz).
    edf : float
        Equivalent degrees of freedom of each bin (:func:`welch_edf`).
    nperseg : int
        Samples per segment.
    resolution_hz : float
        Bin spacing ``rate_hz / nperseg``.
    """

    freq_hz: np.ndarray
    psd: np.ndarray
    edf: float
    nperseg: int
    resolution_hz: float


@dataclass(frozen=True)
class SpectralLine:
    """One spectral line (SI: the record's unit).

    Attributes
    ----------
    frequency_hz : float
        The excess-weighted mean frequency of its bins.
    amplitude : float
        Amplitude ``A`` of the sinusoid ``A sin(2 pi f t)`` (of the input, with ``increment_dt``).
    amplitude_sigma : float
        1-sigma of ``amplitude`` (conservative, module docstring item 6).
    snr : float
        Peak bin over its local floor (power ratio).
    floor : float
        The local noise floor (unit^2/Hz).
    bins : tuple of int
        First and last bin summed.
    """

    frequency_hz: float
    amplitude: float
    amplitude_sigma: float
    snr: float
    floor: float
    bins: tuple


@dataclass(frozen=True)
class LineSearch:
    """The PSD, its local floor, the detection threshold and the lines found.

    Attributes
    ----------
    psd : Psd
    floor : ndarray
        Local noise floor per bin (NaN outside the searched band).
    threshold : float
        Ratio of a bin to its floor above which a line is declared.
    false_alarm : float
        Probability of one or more false lines in the record the threshold allows.
    band_hz : tuple of float
        The searched band.
    floor_edf : float
        Degrees of freedom given to the floor estimate.
    lines : list of SpectralLine
        Strongest first.
    """

    psd: Psd
    floor: np.ndarray
    threshold: float
    false_alarm: float
    band_hz: tuple
    floor_edf: float
    lines: list = field(default_factory=list)


def welch_edf(nperseg: int, n_segments: int, step: int, window: str = "hann") -> float:
    """Equivalent degrees of freedom of a Welch estimate (Percival and Walden 1993, eq. 292b).

    >>> round(welch_edf(1000, 15, 500), 1)
    28.3
    """
    from scipy.signal import get_window

    h = get_window(window, nperseg)
    h = h / math.sqrt(float(np.sum(h * h)))
    acc = 0.0
    for m in range(1, n_segments):
        lag = m * step
        if lag >= nperseg:
            break
        acc += (1.0 - m / n_segments) * float(np.dot(h[:nperseg - lag], h[lag:])) ** 2
    return 2.0 * n_segments / (1.0 + 2.0 * acc)


def welch_psd(x, rate_hz: float, nperseg: int | None = None) -> Psd:
    """One-sided Welch PSD of a record (Hann, 50 % overlap, each segment's mean removed) with its EDF.

    Raises
    ------
    ValueError
        A record shorter than two segments of :data:`MIN_NPERSEG` samples, or non-finite values.
    """
    from scipy.signal import welch

    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1 or not np.all(np.isfinite(x)):
        raise ValueError("record: must be a finite 1-D array")
    n = x.size
    if nperseg is None:
        nperseg = n // DEFAULT_SEGMENTS
    if not (MIN_NPERSEG <= nperseg <= n // 2):
        raise ValueError(f"nperseg: must lie within [{MIN_NPERSEG}, record length / 2 = {n // 2}], got {nperseg} "
                         f"(a record of {n} samples is too short for a line search)" if n < 2 * MIN_NPERSEG else
                         f"nperseg: must lie within [{MIN_NPERSEG}, {n // 2}], got {nperseg}")
    step = nperseg - nperseg // 2
    f, p = welch(x, fs=rate_hz, window="hann", nperseg=nperseg, noverlap=nperseg // 2, detrend="constant",
                 scaling="density", return_onesided=True)
    n_seg = 1 + (n - nperseg) // step
    return Psd(f, p, welch_edf(nperseg, n_seg, step), int(nperseg), float(rate_hz) / nperseg)


def _local_floor(p: np.ndarray, half_window: int, guard: int, edf: float) -> np.ndarray:
    from scipy.stats import chi2

    n = p.size
    floor = np.full(n, np.nan)
    offsets = np.r_[-half_window:-guard, guard + 1:half_window + 1]
    ks = np.arange(half_window + 1, n - half_window)
    if ks.size:
        neigh = p[ks[:, None] + offsets[None, :]]
        floor[ks] = np.median(neigh, axis=1) * edf / chi2.ppf(0.5, edf)
    return floor


def find_lines(x, rate_hz: float, *, false_alarm: float = 0.01, nperseg: int | None = None, half_window: int = 12,
               guard: int = 3, increment_dt: float | None = None, max_lines: int = 20) -> LineSearch:
    """Find the spectral lines of a record (module docstring).

    Parameters
    ----------
    x : array_like
        The record (rate or specific force, SI), evenly sampled at ``rate_hz``.
    false_alarm : float
        Chance of one or more false lines in a record of noise with a smooth spectrum, in (0, 1).
    nperseg : int, optional
        Welch segment length (default ``n // 8``).
    half_window, guard : int
        The floor's neighbourhood (bins either side) and the bins either side of the tested one left out of it.
    increment_dt : float, optional
        The record is increments over ``dt`` divided by ``dt``: amplitudes are corrected by ``1 / sinc(f dt)``.
    max_lines : int
        Most lines listed (the strongest).

    Returns
    -------
    LineSearch
    """
    from scipy.stats import f as f_dist

    if not (0.0 < false_alarm < 1.0):
        raise ValueError(f"false_alarm: must lie in (0, 1), got {false_alarm!r}")
    if not (1 <= guard < half_window):
        raise ValueError(f"guard, half_window: need 1 <= guard < half_window, got {guard}, {half_window}")
    spec = welch_psd(x, rate_hz, nperseg)
    p, nu, df = spec.psd, spec.edf, spec.resolution_hz
    floor = _local_floor(p, half_window, guard, nu)
    nu_f = nu * (half_window - guard) * (2.0 / math.pi)   # 2 (hw - g) neighbours, half independent, median 2/pi
    searched = np.flatnonzero(np.isfinite(floor))
    if searched.size == 0:
        raise ValueError(f"record: too short for a line search ({p.size} bins; the floor needs {2 * half_window + 3})")
    thr = float(f_dist.isf(false_alarm / searched.size, nu, nu_f))
    ratio = np.full(p.size, np.nan)
    # a floor of exactly 0 (a channel constant at its pulse weight around that bin): no line can stand above
    # noise that is not there, unless the bin itself holds power
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio[searched] = np.where(floor[searched] > 0.0, p[searched] / floor[searched],
                                   np.where(p[searched] > 0.0, np.inf, 0.0))
    order = searched[np.argsort(-ratio[searched])]
    order = order[ratio[order] > thr]
    lines, taken = [], np.zeros(p.size, dtype=bool)
    for k in order:
        if taken[k] or len(lines) >= max_lines:
            continue
        excess_peak = p[k] - floor[k]
        leak = any(abs(k - ln[0]) <= half_window and excess_peak < HANN_SIDELOBE * ln[1] for ln in lines)
        lo, hi = max(k - guard, 1), min(k + guard, p.size - 1)
        taken[max(k - 2 * guard, 0):k + 2 * guard + 1] = True
        if leak:
            continue
        fl = floor[k]
        exc = p[lo:hi + 1] - fl
        power = float(np.sum(exc)) * df                      # A^2 / 2
        if power <= 0.0:
            continue
        w = np.clip(exc, 0.0, None)
        f0 = float(np.sum(spec.freq_hz[lo:hi + 1] * w) / np.sum(w))
        s_k = np.clip(exc, 0.0, None)
        sig_sum = float(np.sum(np.sqrt(2.0 / nu * (fl * fl + 2.0 * s_k * fl))))
        sig_floor = (hi - lo + 1) * fl * math.sqrt(2.0 / nu_f)
        sig_power = math.hypot(sig_sum, sig_floor) * df
        amp = math.sqrt(2.0 * power)
        amp_sig = sig_power / amp                              # d(sqrt(2 P)) = dP / sqrt(2 P)
        gain = 1.0
        if increment_dt is not None:
            gain = abs(float(np.sinc(f0 * increment_dt)))
        lines.append((k, excess_peak, SpectralLine(f0, amp / gain, amp_sig / gain, float(ratio[k]), float(fl),
                                                   (int(lo), int(hi)))))
    return LineSearch(spec, floor, thr, float(false_alarm),
                      (float(spec.freq_hz[searched[0]]), float(spec.freq_hz[searched[-1]])), float(nu_f),
                      [ln[2] for ln in lines])
