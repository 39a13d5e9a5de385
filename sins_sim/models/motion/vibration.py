"""Random vibration as filtered noise: non-repeating, random access, O(1) per evaluated time.

:class:`~sins_sim.models.motion.sines.RandomVibration` (a sum of ``K`` tones,
Shinozuka and Jan [1]_) costs ``3 K`` cosines per evaluated time and repeats
with period ``1 / df``. The vibrations here are Gaussian processes obtained
by shaping white noise with a FIR filter (the discrete simulation of coloured
noise of Kasdin [2]_) at a node rate ``fs`` and interpolating between nodes
with a closed form, so that each evaluated time costs a few tens of
nanoseconds and the realisation never repeats.

.. autosummary::

   FilteredNoiseVibration
   Translation
   LinearSines
   LinearRandomVibration
   SumTranslation

Construction (:class:`FilteredNoiseVibration`; :class:`LinearRandomVibration`
is the same with velocity for angle and acceleration for rate)
----------------------------------------------------------------------------

* **The angle is the primary, filtered quantity.** White Gaussian noise
  ``w_n`` at the nodes ``t_n = n / fs`` is filtered into the gyro angle
  ``theta_n = sum_k g_k w_{n-k}`` by a FIR whose response is
  ``sqrt(S(f) fs / 2) / (2 pi f)`` on ``[f_lo, f_hi]`` and 0 elsewhere
  (``S``: the one-sided rate PSD of the table; ``2 / fs`` the one-sided PSD
  of unit white noise [2]_). Shaping the rate instead and integrating it
  would make the angle at ``t`` depend on the whole history (no random
  access, a running sum that loses precision over an hour, and a random
  walk from any residual DC gain of the filter); a filtered angle is
  stationary and bounded by construction, random access is free, and the
  rate is its exact derivative. The filter's gain at 0 Hz is at the level of
  the window's sidelobes (-143 dB of its peak for the test spectrum).
* **Node derivatives from derivative filters.** The taps are samples of a
  continuous kernel ``g(tau) = a(tau) win(tau)``: ``a`` is the inverse
  Fourier transform of the desired response (frequency sampling [4]_ on a
  grid 16 times finer than ``1 / L``, ``L`` taps) and ``win`` the 4-term
  Blackman-Harris window (sidelobes -92 dB, Harris [3]_). The first and
  second derivatives of the same kernel, ``g' = a' win + a win'`` and
  ``g'' = a'' win + 2 a' win' + a win''`` (``a'``, ``a''`` spectrally, the
  window's analytically), filter the same noise into the node rate
  ``theta'_n`` and its derivative ``theta''_n``: samples of one continuous
  process (their spectra agree with ``j omega`` and ``-omega^2`` times the
  angle's to 2e-6 of their peaks).
* **Quintic Hermite interpolation.** Between nodes the angle is the quintic
  matching ``theta``, ``theta'`` and ``theta''`` at both ends
  (:mod:`sins_sim._kernels.vibration`): the angle is C2, the rate C1 and
  piecewise quartic, and the angle increment ``theta(t_b) - theta(t_a)`` is
  the exact integral of the rate (to 4e-18 rad in the tests, at any ``t``:
  the position ``u`` in a segment is computed without the rounding of
  ``t fs``). The gyro angle is ``phi(t) = theta(t) - theta(0)``
  (``phi(0) = 0``, the :class:`~sins_sim.models.motion.base.Motion3D`
  contract).
* **Why quintic at 14.4 kHz.** Interpolating ``exp(j omega t)`` from its
  node samples gives the passband gain ``c_0`` and images at ``f + k fs``
  (``k != 0``) that are part of the simulated motion. For the rate,
  relative to the in-band component, summed over ``|k| <= 3``:

  ===========================  =========  =========  ==========  ==========
  ``f / fs``                   1/28.8     1/14.4     1/7.2       1/3.6
  ===========================  =========  =========  ==========  ==========
  quintic: images              -152 dB    -122 dB    -92 dB      -63 dB
  quintic: ``1 - c_0``         1.1e-9     6.8e-8     4.3e-6      2.6e-4
  cubic (``theta, theta'``)    -84 dB     -67 dB     -49 dB      -31 dB
  piecewise-linear rate        -55 dB     -43 dB     -31 dB      -18 dB
  ===========================  =========  =========  ==========  ==========

  With 2 kHz the top of engine-vibration spectra, the default node rate
  ``max(14400, 7.2 f_hi)`` Hz puts the images at -92 dB or below at
  ``f_hi``, at 0.2 nodes per 72 kHz plant step (the total image power of a
  spectrum falling towards ``f_hi`` is lower: -107 dB for the test
  spectrum, :attr:`FilteredNoiseVibration.image_level_db`, confirmed by a
  Welch spectrum up to 57.6 kHz). A cubic Hermite would need 28.8 kHz for
  -67 dB, i.e. twice the nodes for 25 dB more images; 14.4 kHz divides the
  72 kHz plant rate. The passband droop ``c_0`` (4e-6 at ``f_hi``) is
  divided out of the design. Cost against images (all 3 axes, rate and
  gyro angle at 72 kHz, CPU time on the 2-core test VM, block generation
  included, typical of runs that scatter by +-20 %; test spectrum):

  ================  =========  =========  =========  =========
  ``node_rate_hz``  9600       12000      14400      28800
  ================  =========  =========  =========  =========
  ns per time       35         43         47         80
  images (total)    -90 dB     -99 dB     -107 dB    -137 dB
  ================  =========  =========  =========  =========

* **Noise below the node rate (``generator: decimated_noise``, the
  default).** The nodes are band-limited to ``f_top = f_hi + 4 fs / 2^k``
  (the band widened by the window's edge rounding), far below the node
  Nyquist (``fs / 7.2`` by default). The white noise is therefore drawn at
  ``fs / D`` (``D`` the largest power of two with ``2 D f_top <= fs``, at
  most ``2^k``; ``D = 2`` at 14.4 kHz and 2 kHz, 16 at 400 Hz) and
  zero-stuffed to ``fs`` with the factor ``sqrt(D)``: its average PSD is
  that of unit white noise at ``fs``, and its spectrum is the low-rate
  noise's repeated ``D`` times (the DFT of the stuffed block at bin ``k`` is
  the short block's at ``k mod (M / D)``, so one rfft of ``M / D`` points
  and copies replace the rfft of ``M``). The FIR passes only the first copy
  (the band lies below ``fs / (2 D)``); the others, the images at
  ``k fs / D - f``, fall in its stopband (below 1e-11 of the peak PSD): the
  convolution is the exact band-limited interpolation of the low-rate
  noise, and the node process is stationary with the same PSD as before
  (the variance of a node quantity is the same at each of the ``D`` node
  phases to 2e-14). For ``D = 2``: half the random numbers and a forward
  FFT of half the length (the three inverse FFTs stay). Measured (CPU time,
  same run, 2-core shared VM, 2026-11-27): node generation of one 3-axis
  vibration 1.21 against 1.61 ms per simulated second in a comparison of
  prototypes, in which a recursive shaping filter (16 poles in parallel
  form driven by node-rate noise, its cost alone: no design for an
  arbitrary table) cost 1.09 and float32 FFTs 1.45; the whole vibration
  truth of ``nav-stationary-1h`` (``benchmarks/test_vibration_truth.py``)
  7.0 against 8.1 ms per simulated second. ``generator: node_rate_noise``
  draws the noise at the node rate (``D = 1``): the random sequences of the
  versions before, bit for bit.
* **Single precision (``decimated_noise``).** The noise is drawn in float64
  (the documented keys), rounded once to float32, and the overlap-save
  convolution (forward FFT, spectral products, three inverse FFTs) runs in
  single precision; the nodes are kept as float32 and every segment is
  evaluated in float64 from them, so the angle is still the exact integral
  of the rate. The rounding adds a floor white over the node band: -127 dB
  of the in-band rate PSD in the band, -119 dB (mean; -107 dB the largest
  Welch bin) between ``f_hi`` and the node Nyquist, 5 dB and more below the
  quintic images above the node Nyquist the truth already has (-102.5 dB for
  the test spectrum), and 6 orders of magnitude below a ring laser's
  quantisation noise. Node generation costs about half (the FFTs of 2^17
  points in float32: 1.9 against 4.3 ms for three axes); the vibration truth
  of ``nav-stationary-1h`` 5.9-6.0 against 7.3-8.1 ms per simulated second
  (issue 26, same machine, alternating runs). ``node_rate_noise`` stays in
  float64. The forward FFT of the float32 noise is ``scipy.fft.rfft``:
  numpy 2.4's float32 rfft took 3.7 times as long (2.98 against 0.79 ms for
  3 x 65536 points), a node block then 8.4 against 11.2 ms; the two differ
  by float32 rounding (earlier versions' ``decimated_noise`` sequences
  differ from these at that level).
* **The engine's grid passes.** The mission truth asks for the angular
  vibration on the 72 kHz plant grid and for the translational one at the
  Gauss-Legendre nodes and ends of the 7.2 kHz filter samples. When those
  rates are integer multiples and divisors of the node rate (72 kHz = 5 x
  14.4 kHz; 14.4 kHz = 2 x 7.2 kHz) the positions in a segment are taken
  from the integers, exactly, instead of from the rounded times (which are
  ``eps t`` off: at ``t = 3600`` s, 4e-13 s);
  :meth:`FilteredNoiseVibration.grid_angle_rate` evaluates the quintic in
  the Hermite basis tabulated at the 5 positions
  (:func:`~sins_sim._kernels.vibration.hermite5_grid`) and
  :meth:`LinearRandomVibration.sample_grid` takes the velocity at a
  sample's end as a node value, so the increments are differences of
  consecutive nodes and telescope
  (:func:`~sins_sim._kernels.vibration.hermite5_samples`). The same motion,
  equal to the general evaluation to the rounding of ``t``; measured (CPU
  time, one core, same run, 2026-11-27): the plant grid 0.59 against 1.88 ms
  per simulated second for three axes, the translational pass 0.35 against
  1.64 ms.
* **Blocks.** The noise is drawn in blocks of ``Nb`` nodes,
  block ``b`` of axis ``a`` from ``np.random.default_rng([seed, channel, b])``
  (``channel = a`` for angular, ``3 + a`` for translational vibrations; for
  ``b < 0``: ``[seed, channel + 6, -1 - b]``; seeds below 2^32 so that each
  key is three 32-bit words and no two keys collide), so any block can be
  regenerated (``Nb / D`` samples each). Node block ``b`` is one overlap-save
  FFT convolution of noise blocks ``b - 1`` (its last ``(L - 1) / D``
  samples) and ``b``; the segment
  polynomials of block ``b`` need the first node of block ``b + 1``. The
  last two blocks are cached (and their memory recycled), so sequential
  chunked evaluation costs O(1) per time, and a time anywhere can be
  evaluated first (random access, a few tens of ms for a block). Rate and
  angle are pure functions of (parameters, seed, ``t``): chunks reproduce
  one call bit for bit.
* **Filter length.** ``L = 2^k + 1`` taps with ``2^k >= 16 fs / f_lo``
  (at least 2^10): the window smooths the band edges over
  ``+-4 fs / 2^k <= f_lo / 4``; ``2^k <= 2^16`` (``f_lo >= 3.5`` Hz at
  14.4 kHz). FFT length ``max(2^17, 2^(k+2))``, ``Nb`` = FFT length
  ``- L + 1``: at 14.4 kHz and 20 Hz, ``L = 16385`` and a block is 114688
  nodes (7.96 s); the caches then hold about 90 MB.
* **Normalisation.** The kernel is scaled so that the in-band rate power
  (from the FIR's actual response and ``c_0``) equals the table's
  integral, :attr:`FilteredNoiseVibration.rms_rate_rad_s` squared (the
  images add ``10^(image_level_db / 10)`` of it). The realised PSD
  (:meth:`FilteredNoiseVibration.design_psd`) follows the table within
  0.02 dB except within ``4 fs / 2^k`` of the band edges, and is below
  1e-11 of its peak outside them.

References
----------
.. [1] M. Shinozuka, C.-M. Jan, "Digital simulation of random processes and
   its applications", J. Sound Vib. 25(1), 111-128, 1972.
.. [2] N. J. Kasdin, "Discrete simulation of colored noise and stochastic
   processes and 1/f^alpha power law noise generation", Proc. IEEE 83(5),
   802-827, 1995 (white noise shaped by a digital filter; sampled PSD
   ``2 sigma^2 / fs``).
.. [3] F. J. Harris, "On the use of windows for harmonic analysis with the
   discrete Fourier transform", Proc. IEEE 66(1), 51-83, 1978 (4-term
   Blackman-Harris window).
.. [4] A. V. Oppenheim, R. W. Schafer, *Discrete-Time Signal Processing*,
   3rd ed., Pearson, 2010, sect. 7.5-7.6 (FIR design by windowing and
   frequency sampling).
.. [5] MIL-STD-810H, Method 514.8 "Vibration", 2019 (acceleration spectra
   in g^2/Hz).
"""

from __future__ import annotations

import abc
import functools
import math
import sys
import threading
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
import scipy.fft

from sins_sim import _validate as v
from sins_sim._kernels.vibration import (hermite5_grid, hermite5_samples, hermite5_slope, hermite5_value,
                                         hermite5_value_slope)
from sins_sim.models.motion.base import (_STATIC, Motion3D, _cos_diff, _loglog_segment_integral, _psd_table, _set,
                                         _vec3, radd_zero, superpose)
from sins_sim.models.motion.specific_force import STANDARD_GRAVITY

__all__ = [
    "FilteredNoiseVibration",
    "Translation",
    "LinearSines",
    "LinearRandomVibration",
    "SumTranslation",
    "DEFAULT_NODE_RATE_HZ",
    "GENERATORS",
]

DEFAULT_NODE_RATE_HZ = 14400.0
"""Node rate (Hz) of the filtered-noise vibrations for ``f_hi_hz <= 2000``; above, ``7.2 f_hi_hz``.

Quintic Hermite images of the rate at ``f_hi`` are then at -92 dB (module
docstring); 14.4 kHz divides the 72 kHz plant rate."""

GENERATORS = ("decimated_noise", "node_rate_noise")
"""Noise generators of the filtered-noise vibrations; the first is the default.

``decimated_noise``: white noise at ``node_rate_hz / D`` (``D`` a power of
two, the largest with the band still below ``node_rate_hz / (2 D)``), zero-
stuffed to the node rate inside the same overlap-save convolution (exact
band-limited interpolation, module docstring); ``node_rate_noise``: white
noise at the node rate (the generator before 2026-11, its random sequences).
The two realise the same PSD; ``D = 1`` makes them the same bit for bit."""

_NODE_RATE_PER_F_HI = 7.2  # default node rate / f_hi above 2 kHz (same image level)
_MIN_NODE_RATE_PER_F_HI = 3.0  # images at f_hi: -55 dB
_RESOLUTION = 16.0  # 2^k >= _RESOLUTION fs / f_lo: edge smoothing +-4 fs / 2^k <= f_lo / 4
_MIN_LOG2_TAPS = 10
_MAX_LOG2_TAPS = 16
_DESIGN_OVERSAMPLING = 16  # design grid spacing = fs / (16 2^k): 16 points per 1/L
_MIN_FFT = 2**17  # overlap-save FFT length at least 2^17 (the L - 1 overlap is at most 1/4 of it)
_CACHE_BLOCKS = 2  # noise, node and segment blocks kept per vibration (sequential use needs 2)
_FFT_OUT = int(np.__version__.split(".")[0]) >= 2  # numpy.fft takes out= from numpy 2.0 on


def _np_fft_into(fn, x, n, out):
    """``out[...] = fn(x, n, axis=-1)`` for a ``numpy.fft`` function: into ``out`` on numpy >= 2.0, through one
    temporary before (same values: numpy 1.x computes in double precision, as 2.x does for double input)."""
    if _FFT_OUT:
        fn(x, n, axis=-1, out=out)
    else:
        out[...] = fn(x, n, axis=-1)
_MAX_BLOCK = 2**32  # block indices must fit one SeedSequence word
_SEED_LIMIT = 2**32
_NEGATIVE_BLOCKS = 6  # channel offset of the noise of blocks b < 0
_ANGULAR, _LINEAR = 0, 3  # channel of axis 0 of angular and translational vibrations
_BLACKMAN_HARRIS = (0.35875, 0.48829, 0.14128, 0.01168)
_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)
_GL_X = 0.5 * (_GL_X + 1.0)
_GL_W = 0.5 * _GL_W
_RESPONSE_GRID = 4097  # x = omega h in [0, pi] where c_k is tabulated
_IMAGE_ORDERS = (-3, -2, -1, 1, 2, 3)
_BUILD_LOCK = threading.Lock()


# --- helpers ----------------------------------------------------------------------


def _times(owner, t):
    """``t`` as a flat float64 array and its shape; rejects NaN/inf."""
    arr = np.asarray(t, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{owner}.t: times must be finite")
    return arr.reshape(-1), arr.shape


def _loglog(table, f):
    """The table interpolated linearly in log(f)-log(psd) at ``f`` (clipped to the table)."""
    fr, ps = table[:, 0], table[:, 1]
    fc = np.clip(np.asarray(f, dtype=np.float64), fr[0], fr[-1])
    return np.exp(np.interp(np.log(fc), np.log(fr), np.log(ps)))


def _table_power(table, f_lo, f_hi):
    """Exact ``integral_{f_lo}^{f_hi}`` of the log-log interpolated table."""
    fr, ps = table[:, 0], table[:, 1]
    pts = np.union1d([f_lo, f_hi], fr[(fr > f_lo) & (fr < f_hi)])
    x0, x1 = pts[:-1], pts[1:]
    seg = np.clip(np.searchsorted(fr, x0, side="right") - 1, 0, fr.size - 2)
    n_exp = np.log(ps[seg + 1] / ps[seg]) / np.log(fr[seg + 1] / fr[seg])
    return float(np.sum(_loglog_segment_integral(x0, x1, fr[seg], ps[seg], n_exp)))


def _hermite5_response(x, k):
    """Fourier coefficient ``c_k(x)`` of the quintic Hermite interpolant of ``exp(j x u)``.

    The interpolant of ``exp(j omega t)`` from its node values and first two
    derivatives is ``exp(j omega t) P(t)`` with ``P`` periodic in the node
    spacing ``h``; ``c_k = integral_0^1 p(u) exp(-j (x + 2 pi k) u) du``
    (``x = omega h``, ``p`` the interpolant on one segment) is the gain of the
    component at ``omega + 2 pi k / h``: ``c_0`` the passband, ``k != 0`` the
    images. 24-point Gauss-Legendre quadrature: absolute error below 1e-15
    for ``0 <= x <= pi`` and ``|k| <= 3`` (against 80 points).

    Parameters
    ----------
    x : array_like
        ``omega h`` (rad).
    k : int
        Image order.

    Returns
    -------
    ndarray, complex
    """
    u = _GL_X[None, :]
    x = np.asarray(x, dtype=np.float64).reshape(-1, 1)
    e = np.exp(1j * x)
    d = 1j * x
    s = -x * x
    u2, u3 = u * u, u * u * u
    u4, u5 = u3 * u, u3 * u2
    p = ((1.0 - 10.0 * u3 + 15.0 * u4 - 6.0 * u5)
         + d * (u - 6.0 * u3 + 8.0 * u4 - 3.0 * u5)
         + s * (0.5 * u2 - 1.5 * u3 + 1.5 * u4 - 0.5 * u5)
         + s * e * (0.5 * u3 - u4 + 0.5 * u5)
         + d * e * (-4.0 * u3 + 7.0 * u4 - 3.0 * u5)
         + e * (10.0 * u3 - 15.0 * u4 + 6.0 * u5))
    return np.sum(_GL_W * p * np.exp(-1j * (x + 2.0 * math.pi * k) * u), axis=1)


@functools.lru_cache(maxsize=1)
def _response_table():
    """``x`` grid on ``[0, pi]`` and ``c_k(x)`` for k = 0 and the image orders (tabulated once)."""
    x = np.linspace(0.0, math.pi, _RESPONSE_GRID)
    c0 = _hermite5_response(x, 0).real  # the kernel is symmetric: c_0 is real
    images = {k: np.abs(_hermite5_response(x, k)) ** 2 for k in _IMAGE_ORDERS}
    return x, c0, images


def _log2_taps(f_lo, fs):
    """``k`` with ``L = 2^k + 1`` taps: ``2^k >= 16 fs / f_lo`` (at least 2^10)."""
    return max(_MIN_LOG2_TAPS, math.ceil(math.log2(_RESOLUTION * fs / f_lo) - 1e-12))


def _node_rate(owner, node_rate_hz, f_lo, f_hi):
    """The node rate (default ``max(14400, 7.2 f_hi)``), checked against the band."""
    if node_rate_hz is None:
        fs = max(DEFAULT_NODE_RATE_HZ, _NODE_RATE_PER_F_HI * f_hi)
    else:
        fs = v.positive(owner, "node_rate_hz", node_rate_hz)
    if fs < _MIN_NODE_RATE_PER_F_HI * f_hi:
        raise ValueError(f"{owner}.node_rate_hz: must be >= {_MIN_NODE_RATE_PER_F_HI:g} f_hi_hz = "
                         f"{_MIN_NODE_RATE_PER_F_HI * f_hi:g} Hz (interpolation images), got {fs!r}")
    if _log2_taps(f_lo, fs) > _MAX_LOG2_TAPS:
        lowest = _RESOLUTION * fs / 2.0**_MAX_LOG2_TAPS
        raise ValueError(f"{owner}.f_lo_hz: must be >= {lowest:.6g} Hz at node_rate_hz = {fs:g} "
                         f"(FIR length 2^{_MAX_LOG2_TAPS} + 1), got {f_lo!r}")
    return float(fs)


def _seed(owner, seed):
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < _SEED_LIMIT:
        raise ValueError(f"{owner}.seed: must be an integer in [0, 2**32), got {seed!r}")
    return int(seed)


def _weights(owner, axis_weights):
    weights = _vec3(owner, "axis_weights", axis_weights)
    for i in range(3):
        v.non_negative(owner, f"axis_weights[{i}]", weights[i])
    return weights


# --- filter design ------------------------------------------------------------------


class _Design:
    """FIR shaping filters of one (table, band, node rate); shared by every seed and weight.

    Attributes
    ----------
    fs : float
        Node rate (Hz).
    taps : int
        FIR length ``L = 2^k + 1``.
    fft_size : int
        Overlap-save FFT length ``max(2^17, 4 2^k)``.
    block : int
        Nodes per block ``fft_size - taps + 1``.
    spectra : ndarray (3, fft_size // 2 + 1), complex
        rfft of the value, ``h`` x first-derivative and ``h^2`` x
        second-derivative taps (``h = 1 / fs``), zero-padded to ``fft_size``.
    freqs, slope_psd : ndarray
        Design grid (Hz) and the realised in-band PSD of the derivative
        (rate, acceleration) per unit axis weight, units^2/Hz.
    value_psd : ndarray
        PSD of the node values (angle, velocity) on the same grid, units^2/Hz.
    power : float
        Integral of the table over the band (units^2).
    max_decimation : int
        Largest power of two ``D <= 2^k`` with ``2 D (f_hi + 4 fs / 2^k) <= fs``:
        the band widened by the window's edge rounding stays below
        ``fs / (2 D)``, so the images of noise drawn at ``fs / D`` fall where
        the FIR is in its stopband (``decimated_noise``, module docstring).
    """

    def __init__(self, table, f_lo, f_hi, fs):
        k = _log2_taps(f_lo, fs)
        half = 2 ** (k - 1)
        self.fs = fs
        self.taps = 2 * half + 1
        self.fft_size = max(_MIN_FFT, 4 * 2**k)
        self.block = self.fft_size - self.taps + 1
        top = f_hi + 4.0 * fs / 2**k  # the band widened by the window's edge rounding
        self.max_decimation = 1
        while 2 * (2 * self.max_decimation) * top <= fs and 2 * self.max_decimation <= 2**k:
            self.max_decimation *= 2
        n_design = _DESIGN_OVERSAMPLING * 2**k
        df = fs / n_design
        f = np.arange(n_design // 2 + 1) * df
        # share of each design cell [f - df/2, f + df/2] inside the band
        share = np.clip((np.minimum(f + 0.5 * df, f_hi) - np.maximum(f - 0.5 * df, f_lo)) / df, 0.0, 1.0)
        grid_x, grid_c0, grid_images = _response_table()
        x = 2.0 * math.pi * f / fs
        c0 = np.interp(x, grid_x, grid_c0)
        omega = 2.0 * math.pi * f
        live = share > 0.0
        amp = np.zeros_like(f)
        # value (angle) response sqrt(S fs/2) / omega, corrected for the interpolation's passband
        amp[live] = np.sqrt(_loglog(table, f[live]) * fs / 2.0) / (omega[live] * c0[live]) * share[live]
        m = np.arange(-half, half + 1)
        a0 = np.fft.irfft(amp, n_design)[m]
        a1 = np.fft.irfft(1j * omega * amp, n_design)[m]
        a2 = np.fft.irfft(-omega * omega * amp, n_design)[m]
        tau = m / fs
        span = half / fs
        w0 = np.zeros_like(tau)
        w1 = np.zeros_like(tau)
        w2 = np.zeros_like(tau)
        for q, b in enumerate(_BLACKMAN_HARRIS):  # win = sum b_q cos(pi q tau / span), centred
            r = math.pi * q / span
            w0 += b * np.cos(r * tau)
            w1 -= b * r * np.sin(r * tau)
            w2 -= b * r * r * np.cos(r * tau)
        g0 = a0 * w0
        g1 = a1 * w0 + a0 * w1
        g2 = a2 * w0 + 2.0 * a1 * w1 + a0 * w2
        self.power = _table_power(table, f_lo, f_hi)
        slope = 2.0 / fs * np.abs(np.fft.rfft(g1, n_design)) ** 2 * c0 * c0
        scale = math.sqrt(self.power / (np.sum(slope) * df))
        g0, g1, g2 = g0 * scale, g1 * scale, g2 * scale
        h = 1.0 / fs
        self.spectra = np.stack([np.fft.rfft(g0, self.fft_size), np.fft.rfft(g1 * h, self.fft_size),
                                 np.fft.rfft(g2 * h * h, self.fft_size)])
        self.freqs = f
        self.slope_psd = slope * scale * scale
        self.value_psd = 2.0 / fs * np.abs(np.fft.rfft(g0, n_design)) ** 2
        self._images = (x, grid_x, grid_images)
        for arr in (self.spectra, self.freqs, self.slope_psd, self.value_psd):
            arr.setflags(write=False)

    @functools.cached_property
    def image_level_db(self):
        """Power of the interpolation images of the derivative relative to its in-band power (dB)."""
        x, grid_x, grid_images = self._images
        f = self.freqs
        image = np.zeros_like(f)
        for k in _IMAGE_ORDERS:
            ck2 = np.interp(x, grid_x, grid_images[k])
            image += ck2 * (2.0 * math.pi * (f + k * self.fs)) ** 2
        return float(10.0 * np.log10(np.sum(image * self.value_psd) / np.sum(self.slope_psd)))


@functools.lru_cache(maxsize=4)
def _design(table_key, f_lo, f_hi, fs):
    """The :class:`_Design` of a table (tuple of pairs, SI units); shared across seeds and weights."""
    return _Design(np.array(table_key, dtype=np.float64), f_lo, f_hi, fs)


# --- noise blocks, cache and evaluation ---------------------------------------------------


class _Shaper:
    """Blocks of filtered noise for one vibration: node arrays on demand, cached, evaluated.

    Parameters
    ----------
    owner : str
        Class name for error messages.
    design : _Design
        The shaping filters.
    weights : tuple of 3 floats
        Axis weights.
    seed : int
        Seed in [0, 2^32).
    channel : int
        Channel of axis 0 (``_ANGULAR`` or ``_LINEAR``).
    decimation : int
        ``D``: the noise is drawn at ``fs / D`` and zero-stuffed to ``fs``
        (1: white noise at the node rate; at most ``design.max_decimation``).
    single : bool
        Convolve in single precision and keep the nodes as float32 (the noise is drawn in float64, as
        the keys document, and rounded once); the segments are evaluated in float64 from them.
    """

    def __init__(self, owner, design, weights, seed, channel, decimation=1, single=False):
        self.owner = owner
        self.d = design
        self.decimation = decimation
        self.n_tail = (design.taps - 1) // decimation  # noise samples of the previous block
        self.n_noise = design.block // decimation  # noise samples per block
        self.n_work = design.fft_size // decimation  # noise buffer of one convolution
        # zero-stuffing by D multiplies the noise's spectrum by nothing but repeats it; sqrt(D) keeps
        # the variance per node-rate sample (the PSD) of white noise at fs
        self.weights = np.array(weights, dtype=np.float64) * math.sqrt(decimation)
        self.single = single
        self.dtype = np.float32 if single else np.float64
        self._spectra = design.spectra.astype(np.complex64) if single else design.spectra
        self.live = [a for a in range(3) if weights[a] != 0.0]
        self.seed = seed
        self.channel = channel
        self._tails = OrderedDict()
        self._nodes = OrderedDict()
        self._free = {}
        self._buffers = None
        self._zero = np.zeros(3)
        self._lock = threading.RLock()
        self._value0 = None

    # -- blocks -------------------------------------------------------------------

    def _rng(self, a, b):
        """The generator of noise block ``b`` of axis ``a``."""
        if b >= 0:
            return np.random.default_rng([self.seed, self.channel + a, b])
        return np.random.default_rng([self.seed, self.channel + a + _NEGATIVE_BLOCKS, -1 - b])

    def _noise_tail(self, b):
        """The last ``(L - 1) / D`` samples of noise block ``b``, (n_live, (L - 1) / D) (drawn anew if not kept)."""
        tail = self._tails.get(b)
        if tail is None:
            work = self._work()[0]
            tail = np.empty((len(self.live), self.n_tail))
            for i, a in enumerate(self.live):
                self._rng(a, b).standard_normal(out=work[i, self.n_tail:])
                tail[i] = work[i, self.n_work - self.n_tail:]
            self._keep(self._tails, b, tail)
        return tail

    def _work(self):
        """Reused buffers of one overlap-save convolution: noise (n_live, M / D), the spectrum of the
        noise zero-stuffed to M, a product, and (D > 1) the spectrum of the noise itself."""
        if self._buffers is None:
            d = self.d
            x = np.empty((len(self.live), self.n_work))
            cplx = np.complex64 if self.single else np.complex128
            spec = np.empty((len(self.live), d.fft_size // 2 + 1), dtype=cplx)
            short = np.empty((len(self.live), self.n_work // 2 + 1), dtype=cplx)
            x1 = np.empty(x.shape, dtype=np.float32) if self.single else x
            self._buffers = (x, spec, np.empty_like(spec), short, x1)
        return self._buffers

    def _rfft(self, x, out):
        """``out`` = rfft of the rows of ``x``: scipy's in single precision, numpy's in double.

        numpy's float32 rfft took 3.7 times as long as scipy's here (2.98 against 0.79 ms for 3 x 65536
        points, numpy 2.4, scipy's pocketfft, 2026-11-27; their results differ by float32 rounding); in
        double precision numpy's keeps the ``node_rate_noise`` sequences of earlier versions bit for bit.
        """
        if self.single:
            out[:] = scipy.fft.rfft(x, axis=-1)
        else:
            _np_fft_into(np.fft.rfft, x, None, out)

    def _stuffed_spectrum(self, x, spec, short):
        """``spec`` = rfft of ``x`` zero-stuffed by ``D`` to the FFT length (``x[j]`` at sample ``j D``).

        The DFT of the stuffed sequence at bin ``k`` is ``X[k mod m]``, ``X``
        the DFT of ``x`` (length ``m = M / D``): the noise's spectrum repeated
        ``D`` times, its upper half the conjugate of the lower. One short rfft
        and copies instead of an rfft of length ``M``.
        """
        self._rfft(x, short)
        m = self.n_work
        half = m // 2
        mirror = np.conj(short[:, half - 1:0:-1])
        for j in range(self.decimation // 2):
            base = j * m
            spec[:, base:base + half + 1] = short
            spec[:, base + half + 1:base + m] = mirror
        spec[:, -1] = short[:, 0]  # bin M / 2 = (D / 2) m

    def _take(self, shape):
        """An array of ``shape`` (contents undefined): a recycled block if one is free, else a new one.

        Fresh arrays of several MB cost more to fault in than to fill (4.7 ms
        against 0.5 ms to fill a block of that size), so evicted blocks that no
        view references any more are reused.
        """
        free = self._free.get(shape)
        if free:
            arr = free.pop()
            arr.setflags(write=True)
            return arr
        return np.empty(shape, dtype=self.dtype)

    def _keep(self, cache, b, arr, recycle=False):
        """Cache ``arr`` (read-only) as block ``b``; past the limit drop the least recently used
        block, and with ``recycle`` keep its memory for :meth:`_take`."""
        arr.setflags(write=False)
        cache[b] = arr
        if len(cache) > _CACHE_BLOCKS:
            _, old = cache.popitem(last=False)
            free = self._free.setdefault(old.shape, [])
            # this name and getrefcount's argument hold it: no view outlives it
            if recycle and sys.getrefcount(old) <= 2 and not free:
                free.append(old)

    def _node_block(self, b):
        """Nodes of block ``b`` as (3, 3, fft_size): ``[q, axis, L - 1 + i]`` is quantity ``q`` of node ``b Nb + i``.

        ``q = 0, 1, 2``: value, ``h`` x first derivative, ``h^2`` x second
        derivative (``h = 1 / fs``). One overlap-save convolution of noise
        blocks ``b - 1`` (its last ``(L - 1) / D`` samples) and ``b``,
        zero-stuffed by ``D`` to the node rate.
        """
        blk = self._nodes.get(b)
        if blk is not None:
            self._nodes.move_to_end(b)
            return blk
        d = self.d
        tail = self.n_tail
        live = self.live
        previous = self._noise_tail(b - 1)
        x, spec, prod, short, x1 = self._work()
        x[:, :tail] = previous
        for i, a in enumerate(live):
            self._rng(a, b).standard_normal(out=x[i, tail:])
        self._keep(self._tails, b, x[:, self.n_work - tail:].copy())
        if x1 is not x:
            x1[:] = x  # single precision: the documented float64 draws, rounded once
        if self.decimation == 1:
            self._rfft(x1, spec)
        else:
            self._stuffed_spectrum(x1, spec, short)
        spec *= self.weights[live, None].astype(spec.real.dtype)
        blk = self._take((3, 3, d.fft_size))
        all_live = len(live) == 3
        if not all_live:
            blk[:] = 0.0
        for q in range(3):
            np.multiply(spec, self._spectra[q], out=prod)
            if all_live:
                _np_fft_into(np.fft.irfft, prod, d.fft_size, blk[q])
            else:
                blk[q, live] = np.fft.irfft(prod, d.fft_size, axis=-1)
        self._keep(self._nodes, b, blk, recycle=True)
        return blk

    def _node_range(self, n_lo, n_hi):
        """Nodes ``n_lo .. n_hi + 1`` (segments ``n_lo .. n_hi``): ``(array (3, 3, m), column of node n_lo)``.

        A view of the node block when they lie in one, else a copy of the slices of the blocks they span.
        """
        nb, start = self.d.block, self.d.taps - 1
        b_lo, b_hi = n_lo // nb, (n_hi + 1) // nb
        with self._lock:
            if b_lo == b_hi:
                return self._node_block(b_lo), start + n_lo - b_lo * nb
            parts = []
            for b in range(b_lo, b_hi + 1):
                lo = max(n_lo, b * nb) - b * nb
                hi = min(n_hi + 1, (b + 1) * nb - 1) - b * nb + 1
                parts.append(self._node_block(b)[:, :, start + lo:start + hi])
            return np.concatenate(parts, axis=2), 0

    # -- evaluation ----------------------------------------------------------------

    def _evaluate(self, kernel, t, *extra, outputs=1):
        """``kernel(t, fs, n0, nodes, col, *extra, *outs)`` over the segments the times need; the (N, 3) outputs."""
        outs = tuple(np.empty((t.size, 3)) for _ in range(outputs))
        if t.size == 0:
            return outs
        if not self.live:
            for out in outs:
                out[:] = 0.0
            return outs
        fs, nb = self.d.fs, self.d.block
        n = np.floor(t * fs)  # the kernels' segment index, same operations
        n_lo, n_hi = int(n.min()), int(n.max())
        if not (-_MAX_BLOCK <= n_lo // nb and n_hi // nb < _MAX_BLOCK):
            raise ValueError(f"{self.owner}.t: |t| must stay below {_MAX_BLOCK * nb / fs:.3g} s")
        t = np.ascontiguousarray(t)
        if n_hi - n_lo < 2 * nb:
            kernel(t, fs, n_lo, *self._node_range(n_lo, n_hi), *extra, *outs)
            return outs
        # times far apart: one pass per block
        blocks = np.floor_divide(n, nb)
        order = np.argsort(blocks, kind="stable")
        cuts = np.flatnonzero(np.diff(blocks[order])) + 1
        for idx in np.split(order, cuts):
            lo, hi = int(n[idx].min()), int(n[idx].max())
            parts = tuple(np.empty((idx.size, 3)) for _ in range(outputs))
            kernel(np.ascontiguousarray(t[idx]), fs, lo, *self._node_range(lo, hi), *extra, *parts)
            for out, part in zip(outs, parts):
                out[idx] = part
        return outs

    def value(self, t, offset=None):
        """Angle (velocity) ``x(t) - offset``, (N, 3)."""
        return self._evaluate(hermite5_value, t, self._zero if offset is None else offset)[0]

    def slope(self, t):
        """Rate (acceleration) ``x'(t)``, (N, 3)."""
        return self._evaluate(hermite5_slope, t)[0]

    def since_zero_and_slope(self, t):
        """``(x(t) - x(0), x'(t))`` in one pass, bit for bit :meth:`increment` from 0 and :meth:`slope`."""
        return self._evaluate(hermite5_value_slope, t, self.value0(), outputs=2)

    def grid_since_zero_and_slope(self, i0, n, r):
        """:meth:`since_zero_and_slope` on the grid ``t_m = m / (r fs)``, ``m = i0 + 1 .. i0 + n``, axis-major.

        ``r`` (an integer) grid points per node segment; positions in a segment from the integers
        (:func:`~sins_sim._kernels.vibration.hermite5_grid`), so the values equal those at the rounded
        times to rounding, and are a pure function of ``m``: chunks reproduce one call bit for bit.
        Returns two new ``(n, 3)`` arrays in Fortran order (each axis contiguous).
        """
        value = np.empty((3, n))
        slope = np.empty((3, n))
        if n == 0 or not self.live:
            value[:] = 0.0
            slope[:] = 0.0
            return value.T, slope.T
        fs, nb = self.d.fs, self.d.block
        if not (-_MAX_BLOCK <= (i0 + 1) // r // nb and (i0 + n) // r // nb < _MAX_BLOCK):
            raise ValueError(f"{self.owner}.t: |t| must stay below {_MAX_BLOCK * nb / fs:.3g} s")
        offset = self.value0()
        step = r * nb  # at most one block of segments per pass: the nodes of two blocks at most
        for j in range(0, n, step):
            m = min(step, n - j)
            k_lo, k_hi = (i0 + 1 + j) // r, (i0 + j + m) // r
            hermite5_grid(i0 + j, r, fs, k_lo, *self._node_range(k_lo, k_hi), offset, value[:, j:j + m],
                          slope[:, j:j + m])
        return value.T, slope.T

    def samples(self, k0, n, q, cs):
        """Derivative at the points ``cs`` of samples ``k0 .. k0 + n - 1`` of the grid ``q / fs`` and the value at
        their ``n + 1`` boundaries (:func:`~sins_sim._kernels.vibration.hermite5_samples`): ``(n, len(cs), 3)``
        and ``(n + 1, 3)``; a pure function of the sample index (chunks reproduce one call bit for bit)."""
        slope = np.empty((n, len(cs), 3))
        value = np.empty((n + 1, 3))
        if not self.live:
            slope[:] = 0.0
            value[:] = 0.0
            return slope, value
        fs, nb = self.d.fs, self.d.block
        if not (-_MAX_BLOCK <= k0 * q // nb and (k0 + n) * q // nb < _MAX_BLOCK):
            raise ValueError(f"{self.owner}.t: |t| must stay below {_MAX_BLOCK * nb / fs:.3g} s")
        cs = np.ascontiguousarray(cs, dtype=np.float64)
        step = max(1, nb // q - 1)  # at most one block of segments per pass
        for j in range(0, max(n, 1), step):
            m = min(step, n - j)
            lo, hi = (k0 + j) * q, (k0 + j + m) * q
            hermite5_samples(k0 + j, q, cs, fs, lo, *self._node_range(lo, hi), slope[j:j + m], value[j:j + m + 1])
        return slope, value

    def value0(self):
        """``x(0)`` (3,), computed once."""
        if self._value0 is None:
            with self._lock:
                if self._value0 is None:
                    self._value0 = self.value(np.zeros(1))[0].copy()
        return self._value0

    def increment(self, ta, tb):
        """``x(tb) - x(ta)``, the exact integral of :meth:`slope`, (N, 3)."""
        if not ta.any():  # gyro_angle / velocity since 0: x(0) is kept
            return self.value(tb, self.value0())
        return self.value(tb) - self.value(ta)


class _FilteredNoise:
    """Validation, lazy design and diagnostics shared by the two filtered-noise vibrations.

    Subclasses are frozen dataclasses with the fields ``psd_table``,
    ``f_lo_hz``, ``f_hi_hz``, ``axis_weights``, ``seed``, ``node_rate_hz``,
    ``generator`` and ``_shaper`` and set the class attributes below.
    """

    _OWNER = ""
    _CHANNEL = _ANGULAR
    _TO_SI = 1.0  # table units -> SI units^2/Hz

    def _validate(self):
        owner = self._OWNER
        table, f_lo, f_hi = _psd_table(owner, self.psd_table, self.f_lo_hz, self.f_hi_hz)
        weights = _weights(owner, self.axis_weights)
        seed = _seed(owner, self.seed)
        fs = _node_rate(owner, self.node_rate_hz, f_lo, f_hi)
        if self.generator not in GENERATORS:
            raise ValueError(f"{owner}.generator: must be one of {', '.join(GENERATORS)}, got {self.generator!r}")
        _set(self, "psd_table", tuple((float(a), float(b)) for a, b in table))
        _set(self, "f_lo_hz", f_lo)
        _set(self, "f_hi_hz", f_hi)
        _set(self, "axis_weights", weights)
        _set(self, "seed", seed)
        _set(self, "node_rate_hz", fs)
        _set(self, "_table", table)

    def _noise(self):
        shaper = self._shaper
        if shaper is None:
            with _BUILD_LOCK:
                shaper = self._shaper
                if shaper is None:
                    si = tuple((f, p * self._TO_SI) for f, p in self.psd_table)
                    design = _design(si, self.f_lo_hz, self.f_hi_hz, self.node_rate_hz)
                    decimation = design.max_decimation if self.generator == "decimated_noise" else 1
                    shaper = _Shaper(self._OWNER, design, self.axis_weights, self.seed, self._CHANNEL, decimation,
                                     single=self.generator == "decimated_noise")
                    object.__setattr__(self, "_shaper", shaper)
        return shaper

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_shaper"] = None  # caches and locks are rebuilt on demand
        return state

    def psd(self, f_hz):
        """The log-log interpolated table at ``f_hz`` (table units; 0 outside the band).

        Parameters
        ----------
        f_hz : array_like
            Frequencies (Hz).

        Returns
        -------
        ndarray
            One-sided PSD per unit axis weight.
        """
        f = np.asarray(f_hz, dtype=np.float64)
        inside = (f >= self.f_lo_hz) & (f <= self.f_hi_hz)
        return np.where(inside, _loglog(self._table, f), 0.0)

    def design_psd(self, f_hz):
        """PSD of the realised process at ``f_hz`` (table units), per unit axis weight.

        The in-band part from the FIR's actual response and the interpolation's
        passband ``c_0``: equal to :meth:`psd` within 0.02 dB except within
        ``4 node_rate_hz / 2^k`` (``L = 2^k + 1`` taps) of the band edges, where
        the window rounds the edges off. Interpolation images (above
        ``node_rate_hz - f_hi_hz``) are not included: see :attr:`image_level_db`.

        Parameters
        ----------
        f_hz : array_like
            Frequencies (Hz), ``0 <= f <= node_rate_hz / 2``.

        Returns
        -------
        ndarray
        """
        d = self._noise().d
        return np.interp(np.asarray(f_hz, dtype=np.float64), d.freqs, d.slope_psd) / self._TO_SI

    @property
    def image_level_db(self) -> float:
        """Total power of the interpolation images relative to the in-band power (dB).

        Images sit at ``f + k node_rate_hz`` (``k != 0``, ``|k| <= 3`` summed;
        higher orders are smaller still); computed from the design, checked by a
        Welch spectrum in the tests.
        """
        return self._noise().d.image_level_db

    @property
    def n_taps(self) -> int:
        """Length ``L = 2^k + 1`` of the shaping FIR."""
        return self._noise().d.taps

    @property
    def block_nodes(self) -> int:
        """Nodes per noise block (``block_nodes / node_rate_hz`` seconds)."""
        return self._noise().d.block

    @property
    def noise_decimation(self) -> int:
        """``D``: the white noise is drawn at ``node_rate_hz / D`` (1 for ``node_rate_noise``)."""
        return self._noise().decimation


# --- angular vibration ------------------------------------------------------------------


@dataclass(frozen=True)
class FilteredNoiseVibration(_FilteredNoise, Motion3D):
    """Angular random vibration: white noise shaped by a FIR, quintic Hermite between nodes.

    A stationary Gaussian gyro angle with rate PSD ``w_i^2 S(f)`` on axis
    ``i`` (``S`` the table, zero outside ``[f_lo_hz, f_hi_hz]``), independent
    across axes; the rate is the angle's exact derivative, so rate and gyro
    angle are closed forms at any ``t``. Unlike
    :class:`~sins_sim.models.motion.sines.RandomVibration` it never repeats and
    costs O(1) per evaluated time, whatever the band. Construction,
    interpolation, image level and accuracy: module docstring.

    Parameters
    ----------
    psd_table : sequence of (f_hz, psd) pairs
        One-sided PSD of the angular RATE, ``(rad/s)^2 / Hz``, at strictly
        increasing frequencies > 0 (at least two rows); values > 0.
        Interpolated linearly in log(f)-log(psd).
    f_lo_hz, f_hi_hz : float, optional
        Band (Hz); default the first and last table frequency; must lie in
        the table. ``f_lo_hz >= 16 node_rate_hz / 2^16`` (3.5 Hz at 14.4 kHz).
    axis_weights : float or array_like (3,)
        Amplitude weight per body axis (PSD ``w_i^2 psd``), >= 0.
    seed : int
        Seed in ``[0, 2^32)``. Same seed, same motion.
    node_rate_hz : float, optional
        Node rate ``fs`` (Hz), ``>= 3 f_hi_hz``; default
        ``max(14400, 7.2 f_hi_hz)`` (:data:`DEFAULT_NODE_RATE_HZ`).
    generator : {"decimated_noise", "node_rate_noise"}
        How the white noise is drawn (:data:`GENERATORS`): at the node rate
        divided by :attr:`noise_decimation` (default, cheaper), or at the node
        rate (the sequences of earlier versions). Same PSD either way.

    Notes
    -----
    ``phi_i(t) = theta_i(t) - theta_i(0)`` with ``theta`` the filtered,
    zero-mean angle: bounded over any mission length. Evaluation is random
    access: the noise of block ``b`` is regenerated from
    ``np.random.default_rng([seed, axis, b])`` whenever it is not in the
    cache of the last 2 blocks, so evaluating times in increasing chunks
    costs O(1) per time, and a time far from the cached blocks costs two
    blocks (45-100 ms here). The filter design (35 ms) is shared by
    vibrations that differ only in seed or weights.

    Measured (tests/test_vibration.py, 2-core shared VM): rate and gyro
    angle of 36,000 increasing times at 72 kHz on 3 axes cost 42-51 ns per
    time in CPU time (best of three runs), block generation included (17-25
    ns of it evaluation, the rest noise, FFTs and segment coefficients);
    :meth:`grid_angle_rate` (one kernel pass for both) 2-6 ns less.
    ``RandomVibration`` with the same band and 1980 tones: 8-12 us. Over 60 s the realised rate PSD matches the table
    within Welch's scatter (whole band: -0.012, -0.005, +0.010 dB on the
    three axes, sigma 0.013 dB), the RMS within 0.1 % (sigma 0.16 %), and
    the autocorrelation at 1 s and at one block length is below 0.004.

    Examples
    --------
    >>> import numpy as np
    >>> from sins_sim.models.motion import FilteredNoiseVibration
    >>> vib = FilteredNoiseVibration(((20.0, 1e-3), (2000.0, 1e-3)), seed=1)
    >>> t = np.arange(7200) / 72000.0
    >>> vib.gyro_angle(t).shape, vib.gyro_angle(0.0).tolist()
    ((7200, 3), [0.0, 0.0, 0.0])
    >>> round(float(vib.rms_rate_rad_s[0]), 4)
    1.4071
    """

    psd_table: tuple = ()
    f_lo_hz: float | None = None
    f_hi_hz: float | None = None
    axis_weights: tuple = (1.0, 1.0, 1.0)
    seed: int = 0
    node_rate_hz: float | None = None
    generator: str = GENERATORS[0]
    _shaper: object = field(init=False, repr=False, compare=False, default=None)

    _OWNER = "FilteredNoiseVibration"
    _CHANNEL = _ANGULAR

    def __post_init__(self):
        self._validate()

    def _rate(self, t):
        return self._noise().slope(t)

    def _increment(self, ta, tb):
        return self._noise().increment(ta, tb)

    def grid_angle_rate(self, i0: int, n: int, h: float):
        """Gyro angles and body rates on the grid ``t_j = (i0 + 1 + j) h``, ``j < n`` (the plant steps).

        One kernel pass for both (the engine's fast path). When ``1 / h`` is a
        multiple ``r`` of the node rate (72 kHz and 14.4 kHz: ``r = 5``) each
        segment's polynomial is formed once for its ``r`` steps and the steps'
        positions in it are the exact ``(m mod r) / r`` (``m = i0 + 1 + j``):
        equal to ``gyro_angle(t), body_rate(t)`` to the rounding of ``t``
        (``eps t / 2``), a pure function of the step index (chunks reproduce
        one call bit for bit), axis-major (Fortran order) arrays. Otherwise
        the general kernel at ``t``: equal bit for bit.

        Parameters
        ----------
        i0 : int
            Index of the step before the first (``t_0 = (i0 + 1) h``).
        n : int
            Number of steps.
        h : float
            Step (s).

        Returns
        -------
        angle, rate : ndarray, shape (n, 3)
            Gyro angles (rad) and body rates (rad/s).
        """
        noise = self._noise()
        per_node = 1.0 / (h * noise.d.fs)  # plant steps per node segment
        r = round(per_node)
        if r >= 1 and abs(per_node - r) <= 1e-9 * r:  # the plant rate a multiple of the node rate
            return noise.grid_since_zero_and_slope(i0, n, r)
        t = np.arange(i0 + 1, i0 + n + 1) * h
        return noise.since_zero_and_slope(t)

    def _fixed_axis(self):
        live = [i for i in range(3) if self.axis_weights[i] != 0.0]
        if not live:
            return _STATIC
        if len(live) == 1:
            return np.eye(3)[live[0]]
        return None

    @property
    def rms_rate_rad_s(self):
        """RMS rate per axis (rad/s): ``w_i sqrt(integral_{f_lo}^{f_hi} PSD df)``."""
        return math.sqrt(_table_power(self._table, self.f_lo_hz, self.f_hi_hz)) * np.array(self.axis_weights)


# --- translational vibration --------------------------------------------------------------


class Translation(abc.ABC):
    """Translational vibration of the block: acceleration, zero-mean velocity, exact velocity increments.

    Subclasses implement ``_accel(t)`` and ``_velocity(t)`` (the zero-mean
    velocity, m/s, whose derivative is the acceleration) on flat float64
    arrays, and may override ``_velocity_increment(ta, tb)`` with a form free
    of cancellation. ``+`` builds a :class:`SumTranslation`.

    The three components are along the axes of the frame the block is
    shaken in; the acceleration adds to the specific force the
    accelerometers sense, on top of gravity and the vehicle's motion (for a
    sculling study in body axes, together with an angular
    :class:`~sins_sim.models.motion.sines.AxisSines`; the mission truth,
    ``sins_sim.simulation.truth``, takes them in vehicle axes and rotates
    them into the body). These are not
    :class:`~sins_sim.models.motion.base.Motion3D` (no rotation).
    """

    @abc.abstractmethod
    def _accel(self, t):
        """Acceleration (N, 3) at the flat times ``t`` (m/s^2)."""

    @abc.abstractmethod
    def _velocity(self, t):
        """Zero-mean velocity (N, 3) at the flat times ``t`` (m/s)."""

    def _velocity_increment(self, ta, tb):
        """Exact ``integral_{ta}^{tb} accel dt`` (N, 3) (m/s)."""
        return self._velocity(tb) - self._velocity(ta)

    def accel(self, t):
        """Acceleration of the block (m/s^2), body axes.

        Parameters
        ----------
        t : float or array_like
            Times (s).

        Returns
        -------
        ndarray, shape ``t.shape + (3,)``
        """
        flat, shape = _times("translation", t)
        return self._accel(flat).reshape(shape + (3,))

    def velocity(self, t):
        """Vibration velocity (m/s): the zero-mean antiderivative of :meth:`accel`.

        Parameters
        ----------
        t : float or array_like
            Times (s).

        Returns
        -------
        ndarray, shape ``t.shape + (3,)``
        """
        flat, shape = _times("translation", t)
        return self._velocity(flat).reshape(shape + (3,))

    def velocity_increment(self, t_a, t_b):
        """Exact ``integral_{t_a}^{t_b} accel dt`` (m/s).

        Parameters
        ----------
        t_a, t_b : array_like
            Interval ends (s), broadcast against each other.

        Returns
        -------
        ndarray, shape ``broadcast(t_a, t_b).shape + (3,)``
        """
        ta, tb = np.broadcast_arrays(np.asarray(t_a, dtype=np.float64), np.asarray(t_b, dtype=np.float64))
        shape = ta.shape
        fa, _ = _times("translation", ta)
        fb, _ = _times("translation", tb)
        return self._velocity_increment(fa, fb).reshape(shape + (3,))

    def sample_grid(self, k0: int, n: int, h: float, inner):
        """What the mission truth needs of the vibration over samples ``k0 + 1 .. k0 + n`` of period ``h``.

        Sample ``k`` spans ``[(k - 1) h, k h]``. Subclasses whose node grid divides ``h`` override this with
        positions from the integers (:class:`LinearRandomVibration`); this default evaluates the public methods
        at the rounded times ``t_end = k h``, ``t_start = t_end - h``.

        Parameters
        ----------
        k0 : int
            The sample before the first.
        n : int
            Number of samples.
        h : float
            Sample period (s).
        inner : array_like (G,)
            Points inside each sample, as fractions of it (the Gauss-Legendre nodes).

        Returns
        -------
        accel : ndarray (n, G + 1, 3)
            Acceleration (m/s^2) at the inner points and at the end of each sample.
        dv : ndarray (n, 3)
            The exact velocity increment over each sample (m/s).
        velocity : ndarray (n, 3)
            The velocity at the end of each sample (m/s).
        """
        inner = np.asarray(inner, dtype=np.float64)
        t_end = np.arange(k0 + 1, k0 + n + 1) * h
        t_start = t_end - h
        grid = np.concatenate((t_start[:, None] + inner[None, :] * h, t_end[:, None]), axis=1).reshape(-1)
        accel = np.ascontiguousarray(self._accel(grid).reshape(n, inner.size + 1, 3))
        return accel, np.ascontiguousarray(self._velocity_increment(t_start, t_end)), self._velocity(t_end)

    def __add__(self, other):
        return superpose(self, other, Translation, SumTranslation)

    def __radd__(self, other):
        return radd_zero(self, other)


@dataclass(frozen=True)
class SumTranslation(Translation):
    """The superposition of translational vibrations: accelerations and velocities add.

    Parameters
    ----------
    parts : tuple of Translation
        The vibrations (an empty tuple is no vibration).
    """

    parts: tuple = ()

    def __post_init__(self):
        parts = tuple(self.parts)
        for i, p in enumerate(parts):
            if not isinstance(p, Translation):
                raise ValueError(f"SumTranslation.parts[{i}]: must be a Translation, got {type(p).__name__}")
        _set(self, "parts", parts)

    def _accel(self, t):
        out = np.zeros((t.size, 3))
        for p in self.parts:
            out += p._accel(t)
        return out

    def _velocity(self, t):
        out = np.zeros((t.size, 3))
        for p in self.parts:
            out += p._velocity(t)
        return out

    def _velocity_increment(self, ta, tb):
        out = np.zeros((ta.size, 3))
        for p in self.parts:
            out += p._velocity_increment(ta, tb)
        return out

    def sample_grid(self, k0, n, h, inner):
        accel = np.zeros((n, len(inner) + 1, 3))
        dv = np.zeros((n, 3))
        vel = np.zeros((n, 3))
        for p in self.parts:
            a, d, w = p.sample_grid(k0, n, h, inner)
            accel += a
            dv += d
            vel += w
        return accel, dv, vel


@dataclass(frozen=True)
class LinearSines(Translation):
    """Sinusoidal translational vibration per body axis.

    ``a_i(t) = A_i sin(2 pi f_i t + p_i)``; velocity (zero-mean)
    ``v_i(t) = -A_i / (2 pi f_i) cos(2 pi f_i t + p_i)``; the velocity
    increment is written as ``A_i / w_i 2 sin((x_a + x_b)/2) sin((x_b - x_a)/2)``
    (``x = w_i t + p_i``), free of cancellation for short intervals.

    Parameters
    ----------
    amplitude_m_s2 : float or array_like (3,)
        Acceleration amplitude ``A_i`` (m/s^2), >= 0.
    frequency_hz : float or array_like (3,)
        Frequency ``f_i`` (Hz), > 0.
    phase_rad : float or array_like (3,)
        Phase ``p_i`` (rad).

    Examples
    --------
    >>> from sins_sim.models.motion import LinearSines
    >>> s = LinearSines((9.80665, 0.0, 0.0), 100.0, 0.0)
    >>> float(s.velocity_increment(0.0, 0.005)[0]) == 2 * 9.80665 / (200 * 3.141592653589793)
    True
    """

    amplitude_m_s2: tuple = (0.0, 0.0, 0.0)
    frequency_hz: tuple = (1.0, 1.0, 1.0)
    phase_rad: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        o = "LinearSines"
        amp = _vec3(o, "amplitude_m_s2", self.amplitude_m_s2)
        freq = _vec3(o, "frequency_hz", self.frequency_hz)
        phase = _vec3(o, "phase_rad", self.phase_rad)
        for i in range(3):
            v.non_negative(o, f"amplitude_m_s2[{i}]", amp[i])
            v.positive(o, f"frequency_hz[{i}]", freq[i])
        _set(self, "amplitude_m_s2", amp)
        _set(self, "frequency_hz", freq)
        _set(self, "phase_rad", phase)
        _set(self, "_w", 2.0 * math.pi * np.array(freq))

    def _accel(self, t):
        return np.array(self.amplitude_m_s2) * np.sin(t[:, None] * self._w + np.array(self.phase_rad))

    def _velocity(self, t):
        return -(np.array(self.amplitude_m_s2) / self._w) * np.cos(t[:, None] * self._w + np.array(self.phase_rad))

    def _velocity_increment(self, ta, tb):
        p = np.array(self.phase_rad)
        xa = ta[:, None] * self._w + p
        xb = tb[:, None] * self._w + p
        dx = (tb - ta)[:, None] * self._w
        return -(np.array(self.amplitude_m_s2) / self._w) * _cos_diff(xa, xb, dx)


@dataclass(frozen=True)
class LinearRandomVibration(_FilteredNoise, Translation):
    """Translational random vibration from an acceleration PSD in g^2/Hz (filtered noise).

    The machinery of :class:`FilteredNoiseVibration` with the velocity as the
    filtered, zero-mean quantity and the acceleration its exact derivative:
    random access, streaming, non-repeating, exact velocity increments.
    Engine and airframe vibration spectra are given in g^2/Hz [5]_;
    ``1 g = 9.80665 m/s^2``.

    Parameters
    ----------
    psd_table : sequence of (f_hz, psd) pairs
        One-sided acceleration PSD, ``g^2 / Hz``, at strictly increasing
        frequencies > 0 (at least two rows); values > 0; log-log interpolated.
    f_lo_hz, f_hi_hz : float, optional
        Band (Hz); default the first and last table frequency.
    axis_weights : float or array_like (3,)
        Amplitude weight per body axis, >= 0.
    seed : int
        Seed in ``[0, 2^32)`` (its noise is independent of a
        :class:`FilteredNoiseVibration` with the same seed).
    node_rate_hz : float, optional
        Node rate (Hz), ``>= 3 f_hi_hz``; default ``max(14400, 7.2 f_hi_hz)``.
    generator : {"decimated_noise", "node_rate_noise"}
        How the white noise is drawn (:data:`GENERATORS`): at the node rate
        divided by :attr:`noise_decimation` (default, cheaper), or at the node
        rate (the sequences of earlier versions). Same PSD either way.

    Examples
    --------
    >>> from sins_sim.models.motion import LinearRandomVibration
    >>> vib = LinearRandomVibration(((20.0, 0.04), (2000.0, 0.04)), seed=3)
    >>> round(float(vib.rms_accel_g[0]), 3)
    8.899
    >>> vib.velocity_increment([0.0, 0.5], [0.5, 1.0]).shape
    (2, 3)
    """

    psd_table: tuple = ()
    f_lo_hz: float | None = None
    f_hi_hz: float | None = None
    axis_weights: tuple = (1.0, 1.0, 1.0)
    seed: int = 0
    node_rate_hz: float | None = None
    generator: str = GENERATORS[0]
    _shaper: object = field(init=False, repr=False, compare=False, default=None)

    _OWNER = "LinearRandomVibration"
    _CHANNEL = _LINEAR
    _TO_SI = STANDARD_GRAVITY**2

    def __post_init__(self):
        self._validate()

    def _accel(self, t):
        return self._noise().slope(t)

    def _velocity(self, t):
        return self._noise().value(t)

    def _velocity_increment(self, ta, tb):
        return self._noise().value(tb) - self._noise().value(ta)

    def sample_grid(self, k0, n, h, inner):
        """:meth:`Translation.sample_grid`; when the node rate is a multiple ``q`` of ``1 / h`` (14.4 kHz and
        7.2 kHz: ``q = 2``), one kernel pass at the exact positions of the points
        (:func:`~sins_sim._kernels.vibration.hermite5_samples`): the velocity at a sample's end is a node
        value, the increments are differences of consecutive ones (they telescope exactly). Equal to the
        default evaluation at the rounded times to the rounding of ``t``."""
        noise = self._noise()
        per_sample = h * noise.d.fs  # node segments per sample
        q = round(per_sample)
        if not (q >= 1 and abs(per_sample - q) <= 1e-9 * q):
            return super().sample_grid(k0, n, h, inner)
        cs = np.append(np.asarray(inner, dtype=np.float64), 1.0)
        accel, vel = noise.samples(k0, n, q, cs)
        return accel, np.diff(vel, axis=0), vel[1:]

    @property
    def rms_accel_g(self):
        """RMS acceleration per axis (g): ``w_i sqrt(integral PSD df)``."""
        return math.sqrt(_table_power(self._table, self.f_lo_hz, self.f_hi_hz)) * np.array(self.axis_weights)

    @property
    def rms_accel_m_s2(self):
        """RMS acceleration per axis (m/s^2)."""
        return self.rms_accel_g * STANDARD_GRAVITY
