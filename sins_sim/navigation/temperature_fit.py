"""Bias against temperature, and bias steps: regressions of a sensor axis at rest with its noise's correlation.

:func:`fit_temperature_coefficient` fits the linear temperature coefficient; :func:`scan_bias_step` looks for one
bias step by the same generalised least squares.

Arrays in, numbers out (SI rate or specific force, temperature in deg C).

Model (one axis; Titterton and Weston 2004, ch. 4, the thermal terms of the gyro and accelerometer error
equations, to first order)::

    y(t) = b0 + k (T(t) - T_ref) + n(t)

with ``y`` the rate (gyro) or specific force (accelerometer) along the axis at rest (its constant Earth rate or
gravity component goes into ``b0``), ``T_ref`` the log's mean temperature and ``n`` the sensor's noise. The
noise is correlated (random walk, bias instability), so ordinary least squares would understate the sigma of
``k``; the fit is a two-step feasible generalised least squares (Kariya and Kurata 2004, ch. 2):

1. the record is cut into ``blocks`` equal blocks and ``y`` and ``T`` averaged over each;
   ``k`` by ordinary least squares on the block means;
2. the noise model is fitted to the record ``y`` itself (under the null hypothesis ``k = 0`` it is the noise;
   a temperature effect only adds to it, which errs towards a larger sigma) by its Allan deviation
   (:func:`sins_sim.navigation.allan.fit_allan`: white ``N``, random walk ``K``, flicker ``B``); the covariance
   of the block means is then that of white noise plus a rate random walk started at the log's start
   (IEEE Std 952-1997, Annex C)::

       C_ij = N^2 / L delta_ij + K_eff^2 (min(c_i, c_j) - L / 6 delta_ij)

   (block length ``L``, centres ``c_i``; the mean of a random walk over a block has variance
   ``K^2 (c - L / 6)``). A random walk too weak for the fit to read still moves the block means, and the fit's
   ``K`` from one record is uncertain by tens of per cent, so ``K_eff^2`` is the largest of: the fitted
   ``K^2`` plus the flicker floor folded into a random walk of the same Allan variance at the log's half length
   (``3 (0.664 B)^2 / (T / 2)``), and the whole Allan variance at the longest tau with ``MIN_CLUSTERS``
   clusters read as a random walk at its 95 % chi-square upper bound (``3 sigma^2(tau) / tau``, EDF
   ``clusters - 1``). This errs towards a larger sigma: on simulated logs of white noise and a rate random walk
   the normalised error ``(k - k_true) / sigma`` has an RMS of 0.3 to 0.6 instead of 1;
3. ``k`` and its sigma by generalised least squares with ``C`` (``sigma^2 = [(X^T C^-1 X)^-1]_kk``).

A coefficient is reported as significant when ``|k| > z sigma`` with ``z`` the two-sided normal quantile of
``alpha`` (the caller sets ``alpha``, e.g. 5 % over all the axes tested: Bonferroni). A temperature history that
runs with time (a steady warm-up) cannot tell a temperature coefficient from a drift: ``corr_time`` reports
their correlation, and the rate random walk's covariance is what keeps the sigma honest then.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["StepScan", "TemperatureFit", "fit_temperature_coefficient", "scan_bias_step"]

#: Block means in the regression (or fewer for a short log: at least 20 samples a block).
DEFAULT_BLOCKS = 200
#: Independent clusters a tau needs to bound the random walk (as the Allan fit's reliability threshold).
MIN_CLUSTERS = 10


@dataclass(frozen=True)
class TemperatureFit:
    """The temperature coefficient of one axis.

    Attributes
    ----------
    coefficient : float
        ``k`` (SI unit per deg C).
    sigma : float
        Its 1-sigma (generalised least squares with the fitted noise covariance).
    significant : bool
        ``|k| > z sigma``.
    z : float
        The threshold used.
    t_ref_c : float
        Reference temperature (the log's mean, deg C).
    t_range_c : tuple of float
        The temperatures the log spans (block means).
    ols_sigma : float
        The ordinary least-squares sigma on the block means (white residuals assumed), for comparison.
    corr_time : float
        Correlation of the temperature with time over the log.
    noise : dict
        The noise terms used (SI): ``white`` (N), ``random_walk`` (K fitted), ``random_walk_used`` (K_eff).
    """

    coefficient: float
    sigma: float
    significant: bool
    z: float
    t_ref_c: float
    t_range_c: tuple
    ols_sigma: float
    corr_time: float
    noise: dict


def _block_means(x: np.ndarray, n_blocks: int, m: int) -> np.ndarray:
    return x[:n_blocks * m].reshape(n_blocks, m).mean(axis=1)


def _block_covariance(y: np.ndarray, rate_hz: float, sensor: str, n_blocks: int, block_s: float,
                      s2: float) -> tuple:
    """The covariance of the block means of ``y``'s noise (module docstring, item 2) and the noise terms used;
    ``s2`` the block means' own residual variance, the diagonal where the fit finds no white noise."""
    from scipy.stats import chi2

    from sins_sim.navigation.allan import allan_deviation, fit_allan

    curve = allan_deviation(y - y.mean(), rate_hz)
    c = fit_allan(curve, sensor).coefficients
    white2 = float(c.get("white", 0.0))                           # C_white = N^2
    k2 = 3.0 * float(c.get("random_walk", 0.0))                    # C_rw = K^2 / 3
    duration = y.size / rate_hz
    k2_eff = k2 + 3.0 * float(c.get("flicker", 0.0)) / (duration / 2.0)
    reliable = curve.clusters >= MIN_CLUSTERS
    if np.any(reliable):                                           # all of the longest reliable tau's variance as
        i = int(np.flatnonzero(reliable)[-1])                      # a random walk, at its 95 % upper bound
        edf = max(float(curve.clusters[i]) - 1.0, 1.0)
        upper = 3.0 * curve.adev[i] ** 2 / curve.tau_s[i] * edf / float(chi2.ppf(0.05, edf))
        k2_eff = max(k2_eff, upper)
    centres = (np.arange(n_blocks) + 0.5) * block_s
    cov = k2_eff * np.minimum.outer(centres, centres)
    # a block mean's own scatter: the white part, or where the fit found none the residual's (never zero)
    diag = white2 / block_s if white2 > 0.0 else s2
    cov[np.diag_indices(n_blocks)] += diag - k2_eff * block_s / 6.0
    return cov, {"white": math.sqrt(white2), "random_walk": math.sqrt(k2), "random_walk_used": math.sqrt(k2_eff)}


def fit_temperature_coefficient(y, temperature_c, rate_hz: float, *, sensor: str = "gyro", alpha: float = 0.05,
                                blocks: int = DEFAULT_BLOCKS) -> TemperatureFit:
    """Fit ``y = b0 + k (T - T_ref) + noise`` with the noise's correlation accounted for (module docstring).

    Parameters
    ----------
    y : array_like
        The axis's rate or specific force at rest (SI), evenly sampled at ``rate_hz``.
    temperature_c : array_like
        The temperature at the same samples (deg C).
    sensor : str
        ``gyro`` or ``accel`` (for the Allan fit).
    alpha : float
        Two-sided significance level of the test ``k != 0``.
    blocks : int
        Block means used (fewer when the log has under 20 samples a block).

    Raises
    ------
    ValueError
        Arrays of different lengths, non-finite values, a log too short, a constant temperature.
    """
    from scipy.stats import norm

    y = np.asarray(y, dtype=np.float64)
    temp = np.asarray(temperature_c, dtype=np.float64)
    if y.shape != temp.shape or y.ndim != 1:
        raise ValueError(f"temperature_c: must match the record's shape {y.shape}, got {temp.shape}")
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(temp))):
        raise ValueError("temperature_c: must be finite throughout")
    if not (0.0 < alpha < 1.0):
        raise ValueError(f"alpha: must lie in (0, 1), got {alpha!r}")
    n_blocks = min(int(blocks), y.size // 20)
    if n_blocks < 10:
        raise ValueError(f"record: needs at least 200 samples for a temperature fit, got {y.size}")
    m = y.size // n_blocks
    block_s = m / rate_hz
    yb, tb = _block_means(y, n_blocks, m), _block_means(temp, n_blocks, m)
    t_ref = float(np.mean(temp))
    dtb = tb - t_ref
    if float(np.ptp(tb)) <= 0.0:
        raise ValueError("temperature_c: constant over the log; no coefficient can be fitted")
    x = np.column_stack([np.ones(n_blocks), dtb])
    beta_ols, *_ = np.linalg.lstsq(x, yb, rcond=None)
    res_b = yb - x @ beta_ols
    s2 = float(res_b @ res_b) / (n_blocks - 2)
    ols_sigma = math.sqrt(s2 * np.linalg.inv(x.T @ x)[1, 1])
    cov, noise = _block_covariance(y, rate_hz, sensor, n_blocks, block_s, s2)
    ci = np.linalg.inv(cov)
    info = x.T @ ci @ x
    cov_beta = np.linalg.inv(info)
    beta = cov_beta @ (x.T @ ci @ yb)
    sigma = math.sqrt(float(cov_beta[1, 1]))
    z = float(norm.isf(alpha / 2.0))
    k = float(beta[1])
    t_axis = np.arange(y.size, dtype=np.float64)
    corr = float(np.corrcoef(t_axis, temp)[0, 1]) if np.ptp(temp) > 0 else 0.0
    return TemperatureFit(k, sigma, bool(abs(k) > z * sigma), z, t_ref, (float(tb.min()), float(tb.max())),
                          ols_sigma, corr, noise)


@dataclass(frozen=True)
class StepScan:
    """The most likely bias step of one axis.

    Attributes
    ----------
    found : bool
        ``|z| > threshold``.
    time_s : float
        The block boundary where the step fits best (s from the record's start).
    size : float
        The step (SI, after minus before).
    sigma : float
        Its 1-sigma.
    z : float
        ``size / sigma`` there.
    threshold : float
        The two-sided normal quantile of ``alpha / candidates`` (Bonferroni over the boundaries tried).
    candidates : int
        Block boundaries tried.
    resolution_s : float
        Block length: the time is known to a block.
    """

    found: bool
    time_s: float
    size: float
    sigma: float
    z: float
    threshold: float
    candidates: int
    resolution_s: float


def scan_bias_step(y, rate_hz: float, *, sensor: str = "gyro", alpha: float = 0.05, blocks: int = DEFAULT_BLOCKS,
                   margin: float = 0.05) -> StepScan:
    """Scan a record at rest for one bias step: ``y = b0 + d H(t - t_s) + noise`` at every block boundary ``t_s``
    not within ``margin`` of the record's ends, by the same generalised least squares as the temperature
    coefficient (module docstring; the noise's covariance computed once), and the boundary with the largest
    ``|z|``. A step is found where that ``|z|`` exceeds the Bonferroni threshold over the boundaries tried (the
    chance of a false step at most ``alpha``). A steady drift is part of the noise model (the random walk), so a
    slow trend is not taken for a step.

    Raises
    ------
    ValueError
        Non-finite values, a record too short.
    """
    from scipy.stats import norm

    y = np.asarray(y, dtype=np.float64)
    if y.ndim != 1 or not np.all(np.isfinite(y)):
        raise ValueError("record: must be a finite 1-D array")
    n_blocks = min(int(blocks), y.size // 20)
    if n_blocks < 10:
        raise ValueError(f"record: needs at least 200 samples for a step scan, got {y.size}")
    m = y.size // n_blocks
    block_s = m / rate_hz
    yb = _block_means(y, n_blocks, m)
    s2 = float(np.var(yb, ddof=1))
    cov, _ = _block_covariance(y, rate_hz, sensor, n_blocks, block_s, s2)
    ci = np.linalg.inv(cov)
    lo = max(1, int(math.ceil(margin * n_blocks)))
    hi = min(n_blocks - 1, int(math.floor((1.0 - margin) * n_blocks)))
    ones = np.ones(n_blocks)
    best = None
    for k in range(lo, hi + 1):
        x = np.column_stack([ones, (np.arange(n_blocks) >= k).astype(np.float64)])
        cov_beta = np.linalg.inv(x.T @ ci @ x)
        beta = cov_beta @ (x.T @ ci @ yb)
        sig = math.sqrt(float(cov_beta[1, 1]))
        z = float(beta[1]) / sig
        if best is None or abs(z) > abs(best[3]):
            best = (k, float(beta[1]), sig, z)
    cands = hi - lo + 1
    thr = float(norm.isf(alpha / (2.0 * cands)))
    k, d, sig, z = best
    return StepScan(bool(abs(z) > thr), k * block_s, d, sig, z, thr, cands, block_s)
