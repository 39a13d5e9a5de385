"""Coverage of the Allan terms' 95 % intervals over seeds (issue 36: "Allan terms recovered within their stated
confidence from simulated logs of known ARW, bias instability and RRW").

Each of 50 seeds is a 12 h gyro record at 10 Hz holding three independent noise terms of known size:

- white rate noise, ARW ``N = 0.001 deg/sqrt(h)``: ``sigma^2(tau) = N^2 / tau`` (IEEE Std 952-1997, Annex C);
- flicker rate noise, bias instability ``B = 0.02 deg/h``, synthesised by the fractional-difference filter of
  Kasdin & Walter 1992 (``h_k = h_{k-1} (k - 1/2) / k``, alpha = -1): one-sided PSD ``B^2 / (pi f)``, Allan floor
  ``sqrt(2 ln 2 / pi) B = 0.664 B``;
- a rate random walk ``K = 0.1 deg/h/sqrt(h)``: ``sigma^2(tau) = K^2 tau / 3``.

The three overlap: white dominates below about 20 s, flicker between about 20 s and 1000 s, the random walk
above. Each seed is analysed as a user would (``screen_noise(gyro_allan(x, fs))``), and a term's 95 % interval
(``AllanTerm.ci``) must hold the truth in at least 90 % of the seeds where the term is found (the issue's
criterion), and each term must be found in at least 45 of the 50 seeds.

Why 90 % and not 95 %: with 50 seeds and a true coverage of 95 %, the count covered is binomial(50, 0.95); it falls
below 45 (0.90) with probability 3.8 %; the interval is built conservative (``term_rel``: a bound over correlated
points), so its true coverage is above 95 % and the failure chance lower still.

The intervals must also be informative: a vacuous interval (infinitely wide) would pass any coverage test. Their
median half-width may exceed the half-width the seeds' own scatter shows (1.96 times the sample standard deviation
of ``coefficient / truth``) by at most a factor 2: the conservative bound of ``term_rel`` (linear sums over
correlated points and over the other terms) must not be looser than that.

Seeds are fixed (1000 to 1049), not chosen.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sins_sim.navigation.allan import gyro_allan, screen_noise, term_rel
from sins_sim.units import DEG, DEG_PER_H

FS = 10.0
DURATION_S = 12 * 3600.0
SEEDS = range(1000, 1050)
#: Truths in SI: N (rad/sqrt(s)), B (rad/s), K (rad/s/sqrt(s)).
TRUTH = {"white": 0.001 * DEG / 60.0, "flicker": 0.02 * DEG_PER_H, "random_walk": 0.1 * DEG_PER_H / 60.0}
#: The issue's criteria (see the module docstring).
MIN_COVERAGE = 0.90
MIN_FOUND = 45
#: Largest ratio of the stated half-width to the scatter-based one (see the module docstring).
MAX_WIDTH_RATIO = 2.0


def _flicker(b_si, n, rng):
    """Flicker rate noise of bias instability ``b_si`` (Kasdin & Walter 1992, alpha = -1), by FFT convolution."""
    k = np.arange(1, n)
    h = np.ones(n)
    h[1:] = np.cumprod((k - 0.5) / k)
    w = rng.standard_normal(n) * b_si
    return np.fft.irfft(np.fft.rfft(w, 2 * n) * np.fft.rfft(h, 2 * n), 2 * n)[:n]


def _record(seed):
    rng = np.random.default_rng(seed)
    n = int(DURATION_S * FS)
    white = rng.standard_normal(n) * TRUTH["white"] * math.sqrt(FS)          # PSD N^2: sigma = N sqrt(fs)
    walk = np.cumsum(rng.standard_normal(n)) * TRUTH["random_walk"] / math.sqrt(FS)   # step K sqrt(dt)
    return white + _flicker(TRUTH["flicker"], n, rng) + walk


@pytest.fixture(scope="module")
def readings():
    """Per term: list over seeds of (found, covered, coefficient / truth, interval half-width / coefficient)."""
    out = {name: [] for name in TRUTH}
    for seed in SEEDS:
        terms = screen_noise(gyro_allan(_record(seed), FS)).terms
        for name, truth in TRUTH.items():
            t = terms[name]
            if not t.found:
                out[name].append((False, False, math.nan, math.nan))
                continue
            out[name].append((True, t.ci[0] <= truth <= t.ci[1], t.coefficient / truth,
                              0.5 * (t.ci[1] - t.ci[0]) / t.coefficient))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", list(TRUTH))
def test_term_found_and_covered(readings, name):
    found = [r for r in readings[name] if r[0]]
    assert len(found) >= MIN_FOUND, f"{name}: found in {len(found)} of {len(SEEDS)} seeds"
    covered = sum(r[1] for r in found)
    assert covered / len(found) >= MIN_COVERAGE, f"{name}: {covered} of {len(found)} intervals hold the truth"


@pytest.mark.slow
@pytest.mark.parametrize("name", list(TRUTH))
def test_interval_informative(readings, name):
    ratio = np.array([r[2] for r in readings[name] if r[0]])
    half = np.array([r[3] for r in readings[name] if r[0]])
    scatter_half = 1.96 * np.std(ratio, ddof=1)
    assert np.median(half) <= MAX_WIDTH_RATIO * scatter_half, (name, np.median(half), scatter_half)


def test_term_rel_one_point_closed_form():
    """One point: ``rel = hypot(gain sqrt(2 / edf), others_err / part)`` (``term_rel``), with edf from allantools."""
    import allantools

    from sins_sim.navigation.allan import AllanCurve

    curve = AllanCurve(np.array([10.0]), np.array([1.0]), np.array([1.0]), 100000, 10.0)
    edf = allantools.edf_simple(100000, 100.0, 0)
    s2, part, err = np.array([2.0]), np.array([1.5]), np.array([0.3])
    u = 2.0 / 1.5 * math.sqrt(2.0 / edf)
    assert term_rel("white", [10.0], s2, part, [1.0], curve) == pytest.approx(u, rel=1e-12)
    assert term_rel("white", [10.0], s2, part, [1.0], curve, err) == pytest.approx(math.hypot(u, 0.3 / 1.5),
                                                                                    rel=1e-12)


def test_an_interval_the_chi_square_form_cannot_state_is_none_not_an_overflow():
    """A point whose subtracted terms are uncertain beyond any scale (a nearly empty region's bound, 1e289 in the
    separation study's 3 s records before the cap) has no chi-square interval: None, never an OverflowError."""
    from sins_sim.navigation.allan import AllanCurve, term_interval

    tau = np.array([0.01, 0.02])
    curve = AllanCurve(tau_s=tau, adev=np.ones(2), n_terms=np.array([298.0, 297.0]), n_samples=299,
                       rate_hz=100.0)
    s2, part, w = np.array([1.6e-7, 3.2e-8]), np.array([1.4e-7, 3.6e-8]), np.array([1.0, 0.5])
    assert term_interval("quantization", 1.4e-11, tau, s2, part, w, curve, others_err=np.array([1e289, 5e288])) is None
    lo, hi = term_interval("quantization", 1.4e-11, tau, s2, part, w, curve)
    assert 0.0 < lo < math.sqrt(1.4e-11 / 3.0) < hi  # Q = sqrt(c / 3) (IEEE 952 Annex C) inside its interval
