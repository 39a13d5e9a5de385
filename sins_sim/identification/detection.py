"""Whether an axis has a gap at all: a test of the refit's residual power against the noise floor.

The gap is **significant** on an axis when the baseline refit's mean square residual exceeds the noise
floor's power by more than noise explains, at a stated false-alarm level; the tolerance on the excess
RMS follows from that test and the number of effectively independent samples, so that a small effect in
a long recording is found (issue 24: an axis coupling of 0.14 and 0.07 arcsec RMS over 180,000 samples
fell under a fixed tolerance of half the floor).

The test (:func:`gap_test`)
---------------------------
Under "no gap" the residual on the ``n`` used samples is noise at the floor's level ``sigma^2``. Its mean
square ``ms`` then follows ``sigma^2 chi2_m / m`` with ``m = n / L`` the effectively independent samples
(``L`` the residual's integrated correlation length, ``refit._correlation_length``: the same count the
verdict's F-test and the parameter uncertainties use). The floor (``localise.noise_floor``) is either:

* the readout quantisation ``q / sqrt(12)``, a known number: ``ms / floor^2`` is then tested against
  ``chi2_m / m`` (the chi-square test of a variance; Kendall & Stuart, "The Advanced Theory of
  Statistics" vol. 2, sec. 16.22);
* or the median of ``K`` Welch bins of the residual's high band with ``nu`` degrees of freedom each, an
  estimate with its own ``d = (2 / pi) K nu / 1.94`` degrees of freedom (:func:`floor_dof`: the median's
  efficiency, and neighbouring bins correlated). It is taken from the same residual as ``ms``; since
  ``ms`` is the efficient estimate of a white power, ``cov(ms, floor^2) = var(ms)`` (the covariance of an
  efficient estimator with any unbiased one; Lehmann & Casella 1998, "Theory of Point Estimation",
  sec. 2.5), so ``var(ms / floor^2) = 2 (1/d - 1/m)``, and the ratio is tested against Student's t with
  ``d`` degrees of freedom centred on 1 with that variance. 400 simulated white residuals of 2,000
  samples gave a variance of 0.0030 against 0.0033 predicted, and 21 rejections at 5 %
  (``tests/test_diagnose_detection.py``).

The axis has a gap when the ratio exceeds the law's ``1 - alpha_axis`` quantile ``c``. Equivalently the
excess RMS ``sqrt(ms - floor^2)`` exceeds the tolerance ``floor sqrt(c - 1)``, which shrinks as
``n^(-1/4)`` with the recording's length.

Conservative where the law is approximate:

* quantisation noise is uniform, with a smaller variance of ``r^2`` (``q^4 / 180``) than Gaussian noise
  of the same power (``q^4 / 72``), so the chi-square law overstates the null's spread;
* Student's t has heavier tails than the ratio's nearly normal law;
* the fitted parameters lower the residual power by about ``p sigma^2 / n`` on average; it is not
  credited;
* the floor is the larger of the quantisation and the white estimate, so under "no gap" it is at least
  the true level.

Several axes (and the verdict's "any axis has a gap") are tested at the Sidak level
``alpha_axis = 1 - (1 - alpha)^(1 / n_axes)`` (Sidak 1967, "Rectangular confidence regions for the
means of multivariate normal distributions", J. Amer. Stat. Assoc. 62), so that a recording of
independent axes with no gap is called significant with probability ``alpha``
(``DiagnoseSettings.gap_alpha``, 0.05).

The statistical tolerance is floored by ``abs_tol_arcsec`` (model error the test cannot know about:
integration method and interpolation differences between simulators) and ``rel_tol`` times the floor
(0 by default; a user who wants the former fixed fraction back can set it).

.. autosummary::

   gap_test
   floor_dof
   axis_level
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from sins_sim.identification.refit import _correlation_length

__all__ = ["gap_test", "floor_dof", "axis_level", "HANN_BIN_CORR", "MEDIAN_EFFICIENCY"]

#: Correlation of a Hann-windowed periodogram's bins 1 and 2 apart on white noise: the complex bins correlate
#: as ``sum w^2 exp(-2 pi i k n / N) / sum w^2`` = -2/3 and 1/6 (``w^2 = 3/8 - cos / 2 + cos(2 .) / 8``), their
#: powers as the squares, 4/9 and 1/36 (Percival & Walden 1993, "Spectral Analysis for Physical Applications",
#: sec. 6.6; 3,000 simulated periodograms gave 0.441 and 0.022).
HANN_BIN_CORR = (4.0 / 9.0, 1.0 / 36.0)
#: Asymptotic efficiency of the sample median against the mean for nearly Gaussian data, 2 / pi (Kendall &
#: Stuart vol. 1, sec. 10.10): the median of ``K`` bins carries the information of ``2 K / pi`` of them.
MEDIAN_EFFICIENCY = 2.0 / math.pi


def axis_level(alpha: float, n_axes: int) -> float:
    """The Sidak level of each of ``n_axes`` independent tests whose family has level ``alpha``."""
    return 1.0 - (1.0 - float(alpha)) ** (1.0 / max(1, int(n_axes)))


def floor_dof(floor: dict) -> float:
    """Degrees of freedom of a noise floor's power (``localise.noise_floor``): ``inf`` when the floor is the
    quantisation (a known number), else ``MEDIAN_EFFICIENCY K nu / (1 + 2 (rho_1 + rho_2))`` for the median
    of ``K`` Welch bins of ``nu`` degrees of freedom each, with the correlations ``rho_1, rho_2`` of bins 1
    and 2 apart (:data:`HANN_BIN_CORR`; the variance of a mean of correlated terms)."""
    if floor.get("white_rad", 0.0) <= floor["quantisation_rad"] or not floor.get("n_bins"):
        return math.inf
    return MEDIAN_EFFICIENCY * floor["n_bins"] * floor["bin_dof"] / (1.0 + 2.0 * sum(HANN_BIN_CORR))


def gap_test(residual: np.ndarray, floor: dict, alpha_axis: float) -> dict:
    """The test of one axis' residual power against its noise floor (see the module docstring).

    Parameters
    ----------
    residual : ndarray
        The baseline refit's residual (rad), NaN where not used.
    floor : dict
        Its noise floor (``localise.noise_floor``).
    alpha_axis : float
        The false-alarm level of this axis (:func:`axis_level`).

    Returns
    -------
    dict
        ``ratio`` (``ms / floor^2``), ``critical_ratio``, ``p_value``, ``n_eff`` (effectively independent
        samples), ``correlation_length`` (samples), ``floor_dof``, ``tolerance_rad`` (the excess RMS at
        which the test rejects: ``floor sqrt(critical_ratio - 1)``) and ``alpha``.
    """
    r = np.asarray(residual, dtype=np.float64)
    r = r[np.isfinite(r)]
    fl = float(floor["floor_rad"])
    d2 = floor_dof(floor)
    if r.size < 2 or not fl > 0.0:
        return {"ratio": math.nan, "critical_ratio": math.inf, "p_value": 1.0, "n_eff": float(r.size),
                "correlation_length": 1.0, "floor_dof": d2, "tolerance_rad": math.inf, "alpha": alpha_axis}
    corr = _correlation_length(r)
    m = max(1.0, r.size / corr)
    ratio = float(np.mean(r * r)) / fl ** 2
    if math.isinf(d2):
        law = stats.chi2(m, scale=1.0 / m)
    else:
        # the floor comes from the same residual: cov(ms, floor^2) = var(ms) (ms is the efficient estimate of
        # the power), so var(ms / floor^2) = 2 (1/d - 1/m); Student's t with the floor's d degrees of freedom
        var = 2.0 * max(1.0 / d2 - 1.0 / m, 0.5 / d2)
        law = stats.t(d2, loc=1.0, scale=math.sqrt(var))
    crit = float(law.isf(alpha_axis))
    return {"ratio": ratio, "critical_ratio": crit, "p_value": float(law.sf(ratio)), "n_eff": m,
            "correlation_length": corr, "floor_dof": d2, "tolerance_rad": fl * math.sqrt(max(0.0, crit - 1.0)),
            "alpha": alpha_axis}
