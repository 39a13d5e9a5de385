"""The 90 % NEES rule judged over disjoint sets of seeds (``set_coverage``), on synthetic NEES with closed forms.

A consistent filter's NEES of one seed is chi-square(3) at each epoch. How its epochs are correlated along the run
decides how much the fraction of epochs inside the 95 % interval of a set's mean swings between sets: two
extremes have closed forms. Errors that stay the whole run (one draw per seed) make a set all in or all out, in
with probability 0.95: a Bernoulli per set, one independent epoch (``n_b = 1``). Errors independent per epoch make
the fraction binomial over the K epochs (``n_b = K``). The mean fraction over the sets is 0.95 in both. A filter
told a variance 25 % too large in the run-long case has its set mean inside the interval with probability
``P(chi2(3 N) >= 1.25 N lo)`` (0.55 for N = 50), which the sets' interval rejects while single sets pass half the time.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import binom, chi2
from test_aided_consistency import set_coverage

N_SETS, SET, K = 100, 50, 100


def _nees(run_long: bool, scale: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    shape = (N_SETS * SET, 1 if run_long else K, 3)
    e = rng.standard_normal(shape)
    nees = scale * np.einsum("skj,skj->sk", e, e)
    return np.broadcast_to(nees, (N_SETS * SET, K))[..., None]


def _p_inside(scale: float) -> float:
    lo, hi = chi2.ppf([0.025, 0.975], 3 * SET) / SET
    return float(chi2.cdf(hi * SET / scale, 3 * SET) - chi2.cdf(lo * SET / scale, 3 * SET))


def test_run_long_errors_make_each_set_all_in_or_all_out():
    """One draw per seed for the whole run: each set's fraction is 0 or 1 and ``n_b`` is exactly 1 (the sets'
    variance of a Bernoulli mean ``f`` is ``f (1 - f)``); the number of sets in is binomial(100, 0.95): the mean
    lies inside the binomial's 99.9 % range, and the interval of the mean contains 0.95."""
    out = set_coverage(_nees(True, 1.0, 1), SET)
    f = out["fractions"][:, 0]
    assert set(np.unique(f)) <= {0.0, 1.0}
    assert out["n_b"][0] == pytest.approx(1.0, rel=1e-12)
    lo, hi = binom.ppf([0.0005, 0.9995], N_SETS, 0.95) / N_SETS
    assert lo <= out["mean"][0] <= hi
    assert out["interval"][0, 0] <= 0.95 <= out["interval"][0, 1]


def test_independent_epochs_give_their_count():
    """Independent epochs: the fraction of a set is binomial(K, p) / K with ``p`` the closed-form 0.95, so
    ``n_b = K``; estimated from the variance of 100 sets (relative sd sqrt(2 / 99) = 0.14), within a factor 1.7
    (beyond 3.5 sd)."""
    out = set_coverage(_nees(False, 1.0, 2), SET)
    assert K / 1.7 <= out["n_b"][0] <= K * 1.7
    assert out["interval"][0, 0] <= _p_inside(1.0) <= out["interval"][0, 1]


def test_a_variance_told_25_percent_too_large_is_rejected_over_sets():
    """Run-long errors with the filter's variance 1.25 times the truth's (NEES scaled by 0.8): a set is inside with
    probability 0.55 (closed form), so single sets pass the 90 % rule half the time; over 100 sets the interval's
    upper end falls below 0.90 (its width over 100 Bernoulli trials about +-0.1 around 0.55)."""
    assert _p_inside(0.8) == pytest.approx(0.55, abs=0.03)
    out = set_coverage(_nees(True, 0.8, 3), SET)
    assert out["interval"][0, 1] < 0.90
    single = out["fractions"][:, 0]
    assert 0.3 < np.mean(single >= 0.9) < 0.8


def test_needs_two_sets():
    with pytest.raises(ValueError, match="at least two sets"):
        set_coverage(np.ones((60, 10, 3)), 50)
