"""The Allan noise terms recovered from synthetic records of known N, B, K and R (IEEE Std 952-1997, Annex C).

Each record holds one term of known size:

- white rate noise (angle random walk ``N``): ``sigma^2(tau) = N^2 / tau``;
- flicker rate noise (bias instability ``B``), synthesised with the one-sided PSD ``B^2 / (pi f)`` (IEEE Std 952's
  two-sided ``B^2 / (2 pi f)``): ``sigma^2 = (2 ln 2 / pi) B^2``, the floor ``0.664 B``;
- a rate random walk (``K``): ``sigma^2 = K^2 tau / 3`` (the discrete walk adds ``K^2 dt / (6 m)``, a relative
  ``1 / (2 m^2)``: below 5e-5 for the ``m >= 100`` used in the deviation checks);
- a deterministic rate ramp ``R t``: ``sigma(tau) = R tau / sqrt(2)`` exactly (Annex C, C.7).

Checked twice: the deviations at chosen taus (``sins_sim.navigation.allan.allan_deviation``, and allantools'
``oadev`` on the integrated record as the independent computation) lie in the chi-square confidence interval of
their equivalent degrees of freedom (Greenhall's EDF, ``allantools.edf_greenhall``; Riley 2008, sec. 5.3) around
the closed form; and the coefficient ``fit_allan`` reads from the term's region lies within a bound derived from
the same EDFs (see ``_reading_bound``). The ramp is deterministic and read to rounding.

Confidence levels: each deviation check is two-sided at 1e-4; 36 checks in all, so a fresh seed would fail one
with probability below 0.4 % (union bound). Seeds are fixed.
"""

from __future__ import annotations

import math

import allantools
import numpy as np
import pytest
from scipy import stats

from sins_sim.navigation.allan import FLICKER_FLOOR_FACTOR, allan_deviation, fit_allan

FS = 100.0
#: 2^20 samples at 100 Hz (2.9 h): four decades of tau with at least 10 clusters.
N_SAMPLES = 2 ** 20
#: Taus of the deviation checks, in samples (points of the curve's log grid): within [10, 10000] the band-limited
#: flicker synthesis departs from the ideal floor by less than 0.7 % (its exact expected Allan variance, the sum over
#: the synthesised lines of ``S(f_k) df 2 sin^4(pi f_k tau) / (m sin(pi f_k / fs))^2``, against
#: ``2 ln 2 B^2 / pi``: 0.63 % at m = 10, 0.010 % at m = 100, 4e-7 at m = 1000, -0.011 % at m = 10000, -1.1 % at
#: m = 1e5).
M_CHECK = (100, 1000, 10000)
#: Relative bias of the synthesis allowed on the variance in the flicker checks (above: < 0.011 % over M_CHECK).
FLICKER_BIAS = 2e-4
LEVEL = 1e-4
N_ARW = 1e-4          # rad/sqrt(s)  (0.34 deg/sqrt(h))
B_BI = 1e-5           # rad/s        (2 deg/h)
K_RRW = 1e-6          # rad/s/sqrt(s)
R_RAMP = 1e-7         # rad/s^2
#: Power-law exponent alpha of the rate's PSD (``S_y ~ f^alpha``) of each noise term, for the EDF.
ALPHA = {"white": 0, "flicker": -1, "random_walk": -2}


def _record(term: str, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    if term == "white":
        return rng.standard_normal(N_SAMPLES) * N_ARW * math.sqrt(FS)
    if term == "random_walk":
        return np.cumsum(rng.standard_normal(N_SAMPLES) * K_RRW / math.sqrt(FS))
    if term == "flicker":
        # spectral lines with E|X_k|^2 = S(f_k) fs n / 2, so the one-sided periodogram is S(f) = B^2 / (pi f)
        f = np.fft.rfftfreq(N_SAMPLES, 1.0 / FS)
        s = np.zeros_like(f)
        s[1:] = B_BI ** 2 / (math.pi * f[1:])
        x = (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) * np.sqrt(s * FS * N_SAMPLES / 4.0)
        x[0] = 0.0
        x[-1] = x[-1].real * math.sqrt(2.0)  # the Nyquist line is real
        return np.fft.irfft(x, N_SAMPLES)
    raise AssertionError(term)


def _closed_form_var(term: str, tau):
    tau = np.asarray(tau, dtype=float)
    return {"white": N_ARW ** 2 / tau,
            "flicker": np.full_like(tau, 2.0 * math.log(2.0) / math.pi * B_BI ** 2),
            "random_walk": K_RRW ** 2 * tau / 3.0}[term]


def _edf(term: str, m: int) -> float:
    # Greenhall's EDF of the overlapping Allan variance; the frequency record of n samples is n + 1 phase points
    return float(allantools.edf_greenhall(alpha=ALPHA[term], d=2, m=int(m), N=N_SAMPLES + 1, overlapping=True,
                                          modified=False))


TERMS = ("white", "flicker", "random_walk")


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("term", TERMS)
def test_deviation_in_the_edf_confidence_interval_of_the_closed_form(term, seed):
    """At tau = 1, 10, 100 s: the closed-form variance lies in the two-sided 1e-4 chi-square interval of the
    measured one, ``[s^2 edf / chi2_{1-p/2}, s^2 edf / chi2_{p/2}]`` (widened by the flicker synthesis' bias).
    The project's deviation equals allantools' oadev of the integrated record (phase data) to rounding."""
    x = _record(term, seed)
    curve = allan_deviation(x, FS)
    idx = [int(np.argmin(np.abs(curve.tau_s * FS - m))) for m in M_CHECK]  # the log grid's nearest points
    taus = curve.tau_s[idx]
    _, ad_phase, _, _ = allantools.oadev(np.concatenate(([0.0], np.cumsum(x) / FS)), rate=FS, data_type="phase",
                                         taus=taus)
    for i, tau, ad_ref in zip(idx, taus, ad_phase):
        m = int(round(tau * FS))
        assert abs(m / M_CHECK[idx.index(i)] - 1.0) < 0.05  # within a grid step of the intended tau
        s2 = curve.adev[i] ** 2
        # the cumulative sum's rounding: ~n eps relative on a phase of ~sqrt(n) increments, far below 1e-6
        assert curve.adev[i] == pytest.approx(ad_ref, rel=1e-6)
        edf = _edf(term, m)
        lo = s2 * edf / stats.chi2.isf(LEVEL / 2, edf)
        hi = s2 * edf / stats.chi2.ppf(LEVEL / 2, edf)
        bias = FLICKER_BIAS if term == "flicker" else 1.0 / (2.0 * m * m)
        th = float(_closed_form_var(term, tau))
        assert lo * (1 - bias) <= th <= hi * (1 + bias), (term, m, s2 / th)


def _reading_bound(analysis, term: str) -> float:
    """Bound on the relative error of the coefficient ``fit_allan`` reads for ``term`` (z = 4).

    The reading is ``c = sum w r b / sum w b^2`` over the region's points (``r`` the variance less the other
    terms, ``b = tau^p``, ``w = 1 / (model rel)^2``); with one term, ``r_i = c b_i (1 + e_i)`` and
    ``c_hat / c - 1 = sum u_i e_i / sum u_i`` with ``u_i = w_i b_i^2`` proportional to ``rel_i^-2``
    (``rel_i = max(sqrt(2 / (clusters_i - 1)), 0.05)``, ``fit_allan``). The points are correlated (overlapping
    estimates), so their sds add (Minkowski): ``sd(c_hat / c) <= sum u_i sd(e_i) / sum u_i``, with
    ``sd(e_i) = sqrt(2 / edf_i)`` the chi-square variance's relative sd. The coefficient is ``sqrt(c)`` (times a
    constant): half of it.
    """
    t = analysis.terms[term]
    curve = analysis.curve
    sel = (curve.tau_s >= t.tau_range_s[0]) & (curve.tau_s <= t.tau_range_s[1])
    cl = curve.clusters[sel]
    rel = np.maximum(np.sqrt(2.0 / np.maximum(cl - 1.0, 1.0)), 0.05)
    u = rel ** -2
    m = np.round(curve.tau_s[sel] * curve.rate_hz)
    sd_e = np.array([math.sqrt(2.0 / _edf(term, mm)) for mm in m])
    return 4.0 * 0.5 * float(np.sum(u * sd_e) / np.sum(u))


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("term, truth", [("white", N_ARW), ("flicker", B_BI), ("random_walk", K_RRW)])
def test_fit_reads_the_coefficient_within_its_edf_bound(term, truth, seed):
    """N, B and K read by ``fit_allan`` from their regions: within the EDF-derived bound of the truth, a region
    of at least three decades (the record holds one term), and the other terms negligible there."""
    a = fit_allan(allan_deviation(_record(term, seed), FS))
    t = a.terms[term]
    assert t.found and t.tau_range_s[1] / t.tau_range_s[0] >= 1e3
    bound = _reading_bound(a, term)
    assert bound < 0.1  # the test can tell a 10 % conversion error
    assert abs(t.coefficient / truth - 1.0) <= bound, (t.coefficient / truth, bound)


def test_flicker_floor_factor_is_the_ieee_constant():
    """sqrt(2 ln 2 / pi) = 0.6643 (IEEE Std 952-1997, Annex C)."""
    assert FLICKER_FLOOR_FACTOR == pytest.approx(0.66428, abs=1e-5)


@pytest.mark.parametrize("r", [R_RAMP, 3.7e-5])
def test_rate_ramp_of_known_r(r):
    """A rate ramp ``R t`` has ``sigma(tau) = R tau / sqrt(2)`` at every tau (the Allan variance of a linear
    sequence is exact: each second difference of the cluster means is ``R tau``). allantools' deviation equals
    it to rounding, and ``fit_allan`` reads R (its ramp term alone, ``R = sqrt(2 C)``) to rounding: the data are
    exactly the power law, so the weighted least squares returns it up to floating-point error (1e-9 relative
    allows for ~1e7 eps of accumulated rounding in the sums over 1e6 samples)."""
    n = 2 ** 16
    x = r * (np.arange(n) + 0.5) / FS  # the mean rate over each sample
    curve = allan_deviation(x, FS)
    assert np.allclose(curve.adev, r * curve.tau_s / math.sqrt(2.0), rtol=1e-9, atol=0.0)
    a = fit_allan(curve)
    ramp = a.terms["ramp"]
    assert ramp.found
    assert ramp.coefficient == pytest.approx(r, rel=1e-9)
    assert a.line("ramp", 10.0) == pytest.approx(r * 10.0 / math.sqrt(2.0), rel=1e-9)
    assert ramp.slope_measured == pytest.approx(1.0, abs=1e-9)
