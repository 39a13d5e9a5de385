"""The verdict's decision rules on both sides of each threshold, with constructed candidates (no simulation).

``sins_sim.identification.verdict`` decides from numbers: block losses, training sums of squares, gap fractions.
Each rule is fed inputs built to sit on one side of its threshold and then the other, so that a rule changed in the
code (an ``and`` turned ``or``, a ``max`` turned ``min``, a degree of freedom off by one) changes an outcome here:

- significance needs *both* the held-out Diebold-Mariano test and the nested F-test (``assess``);
- ``closes``: the excess left on every axis within ``max(tolerance, close_fraction * sqrt(excess0))``;
- the Diebold-Mariano p-value against an independent computation (hand-made statistic, ``scipy.stats.t`` with
  ``m - 1`` degrees of freedom, Harvey, Leybourne & Newbold 1997), and a statistic placed between the
  ``t_{m-1}`` and ``t_m`` critical values;
- the F-test p-value against ``scipy.stats.f`` with the extra-sum-of-squares statistic (Bates & Watts 1988,
  sec. 3.5);
- the first step's fractions: ``MIN_PARTIAL``, ``min_gap_reduction`` and ``DOMINANT`` (``keep_dominant``).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from sins_sim.identification import verdict as vd
from sins_sim.identification.refit import DiagnoseSettings
from sins_sim.units import ARCSEC

#: Samples, block length and axis of the constructed recordings: 20 blocks of 200 samples, even blocks train,
#: odd blocks held out (m = 10 held-out blocks).
N, BLOCK = 4000, 200
AXIS = "x"


def _masks():
    block = np.arange(N) // BLOCK
    return block % 2 == 0, np.ones(N, dtype=bool), block


def _fit(residual):
    r = np.asarray(residual, dtype=np.float64)
    return SimpleNamespace(residual=r, rms=float(np.sqrt(np.mean(r * r))), heldout_rms=float(np.sqrt(np.mean(r * r))))


def _reference():
    """White residual of 1 urad RMS (seeded): the model the candidates extend."""
    return np.random.default_rng(7).standard_normal(N) * 1e-6


def _candidate(residual, gap_reduction=0.9, name="constructed"):
    # an effect name outside the catalogue: ``unresolved`` has no class to ask and returns None
    return {"effect": name, "fits": {AXIS: _fit(residual)}, "params": {AXIS: {}}, "gap_reduction": gap_reduction,
            "n_params": 1}


def _scaled(ref, block, train_factor, held_factors):
    """``ref`` times ``train_factor`` on the training blocks and ``held_factors[k]`` on held-out block k."""
    out = ref.copy()
    train = block % 2 == 0
    out[train] *= train_factor
    held_ids = np.unique(block[~train])
    for k, b in enumerate(held_ids):
        out[block == b] *= held_factors[k]
    return out


def _assess(cands):
    train, used, _ = _masks()
    vd.assess(cands, {AXIS: _fit(_reference())}, [AXIS], train, used, 5)
    return cands


# --- significance: both tests must reject ---------------------------------------------------------------------------
def test_significance_needs_both_the_heldout_test_and_the_f_test():
    """Four candidates, one per corner of (held-out better?, training better?).

    Held-out better: every held-out block's residual scaled by 0.5-0.6 (loss differential ln(1/f^2) in 1.0-1.4 over
    10 blocks: t about 20, p ~ 1e-9 << ALPHA); otherwise the held-out blocks are the reference's own (d = 0,
    p = 1). Training better: the training residual halved (F = 3 RSS_new / k / (RSS_new / dof) ~ 6000 on
    ~2000 independent samples, p ~ 0); otherwise equal RSS (F = 0, p = 1). Only the corner where both reject is
    significant; "or" in place of "and" would make two more so.
    """
    ref = _reference()
    _, _, block = _masks()
    better = np.linspace(0.5, 0.6, 10)
    same = np.ones(10)
    corners = {(True, True): _candidate(_scaled(ref, block, 0.5, better)),
               (True, False): _candidate(_scaled(ref, block, 1.0, better)),
               (False, True): _candidate(_scaled(ref, block, 0.5, same)),
               (False, False): _candidate(_scaled(ref, block, 1.0, same))}
    _assess(list(corners.values()))
    for (held, fit), c in corners.items():
        assert (c["p_heldout"] < vd.ALPHA) == held, (held, fit, c["p_heldout"])
        assert (c["p_f"] < vd.ALPHA) == fit, (held, fit, c["p_f"])
        assert c["significant"] == (held and fit), (held, fit)


def test_significance_needs_a_positive_gap_reduction():
    """Both tests reject, but the candidate removes none of the gap (gap_reduction 0): not significant."""
    ref = _reference()
    _, _, block = _masks()
    c = _candidate(_scaled(ref, block, 0.5, np.linspace(0.5, 0.6, 10)), gap_reduction=0.0)
    _assess([c])
    assert c["p_heldout"] < vd.ALPHA and c["p_f"] < vd.ALPHA
    assert not c["significant"]


# --- the Diebold-Mariano statistic and its degrees of freedom ------------------------------------------------------
def _dm_by_hand(d):
    """``t = mean(d) / (sd(d) / sqrt(m))`` written out (sample sd with m - 1), one-sided p from Student's t_{m-1}:
    the held-out test before issue 39 (``dm_pvalue_iid``)."""
    m = len(d)
    mean = sum(d) / m
    sd = math.sqrt(sum((x - mean) ** 2 for x in d) / (m - 1))
    t = mean / (sd / math.sqrt(m))
    return t, float(stats.t.sf(t, m - 1))


def _dm_hac_by_hand(d):
    """The held-out test since issue 39, written out with loops: the Newey-West long-run variance with the
    Bartlett weights and ``L = max(1, min(m - 2, floor(4 (m/100)^(2/9))))`` lags (Newey & West 1987, eq. 2;
    1994), ``DM = mean / sqrt(S / m)``, the Harvey-Leybourne-Newbold factor with ``h = L + 1``
    (1997, eq. 9), one-sided p from Student's t_{m-1}."""
    m = len(d)
    mean = sum(d) / m
    lags = max(1, min(m - 2, math.floor(4.0 * (m / 100.0) ** (2.0 / 9.0))))
    gamma = [sum((d[k] - mean) * (d[k - j] - mean) for k in range(j, m)) / m for j in range(lags + 1)]
    var = gamma[0] + 2.0 * sum((1.0 - j / (lags + 1.0)) * gamma[j] for j in range(1, lags + 1))
    h = lags + 1
    # the factor's numerator held at >= 1 (it is 2/3 at m = 3, h = 2, where the correction would inflate DM)
    t = mean / math.sqrt(var / m) * math.sqrt(max(m + 1.0 - 2.0 * h + h * (h - 1.0) / m, 1.0) / m)
    return t, float(stats.t.sf(t, m - 1))


@pytest.mark.parametrize("d", [[0.3, -0.1, 0.2, 0.05], [0.02, 0.01, -0.03, 0.04, 0.0, 0.05, 0.01],
                               [-0.2, 0.1, -0.05]])
def test_dm_pvalue_against_a_hand_computed_statistic(d):
    """Losses ``loss_ref = exp(d)``, ``loss_new = 1`` make the loss differential exactly ``d``; the p-value equals
    the hand computation to rounding (1e-12 relative: a few operations on numbers of order one), for the test in
    use and for the independent-blocks form kept to measure its calibration."""
    _, p = _dm_hac_by_hand(d)
    assert vd.dm_pvalue(np.exp(d), np.ones(len(d))) == pytest.approx(p, rel=1e-12, abs=1e-15)
    _, p_iid = _dm_by_hand(d)
    assert vd.dm_pvalue_iid(np.exp(d), np.ones(len(d))) == pytest.approx(p_iid, rel=1e-12, abs=1e-15)


def test_dm_degrees_of_freedom_decide_a_statistic_between_the_two_critical_values():
    """m = 4 blocks, DM* = 4.0 exactly: t_{3} gives p = 0.0140 > ALPHA = 0.01 (not significant), t_{4} would give
    p = 0.0081 < ALPHA. The candidate's held-out losses carry that differential through ``assess``: it must not be
    significant, though its training fit is far better (p_f ~ 0)."""
    z = np.array([-1.5, -0.5, 0.5, 1.5])
    z = z / np.std(z, ddof=1)  # mean 0, sample sd 1
    s = 0.1
    t_unit, _ = _dm_hac_by_hand(list(1.0 + s * z))  # DM* is linear in the mean at fixed deviations
    mu = 4.0 / t_unit
    d = mu + s * z
    t, p = _dm_hac_by_hand(list(d))
    assert t == pytest.approx(4.0, rel=1e-12)
    assert stats.t.sf(4.0, 3) > vd.ALPHA > stats.t.sf(4.0, 4)  # the threshold sits between the two
    assert vd.dm_pvalue(np.exp(d), np.ones(4)) == pytest.approx(p, rel=1e-12)
    # the same through assess: 8 blocks, 4 held out, each held-out block's loss lowered by exp(-d_k)
    n_block = 8
    n = n_block * BLOCK
    block = np.arange(n) // BLOCK
    train = block % 2 == 0
    ref = np.random.default_rng(3).standard_normal(n) * 1e-6
    new = ref.copy()
    new[train] *= 0.5
    for k, b in enumerate(np.unique(block[~train])):
        new[block == b] *= math.exp(-0.5 * d[k])
    c = _candidate(new)
    vd.assess([c], {AXIS: _fit(ref)}, [AXIS], train, np.ones(n, dtype=bool), 5)
    assert c["p_heldout"] == pytest.approx(p, rel=1e-9)  # the losses pass through squares, means and logs
    assert c["p_f"] < 1e-6
    assert not c["significant"]
    # and a statistic just past the t_3 critical value is significant
    d2 = 1.2 * mu + s * z  # DM* = 4.8 > t_3 critical 4.54
    assert vd.dm_pvalue(np.exp(d2), np.ones(4)) < vd.ALPHA < stats.t.sf(4.0, 3)


def test_dm_pvalue_needs_three_blocks():
    assert vd.dm_pvalue(np.exp([1.0, 1.1]), np.ones(2)) == 1.0


# --- the nested F-test --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("rss_ref, rss_new, k, p, n_eff", [(1.10, 1.00, 1, 6, 200.0), (1.02, 1.00, 3, 9, 500.0),
                                                          (5.0, 1.0, 2, 8, 40.0)])
def test_f_pvalue_against_scipy(rss_ref, rss_new, k, p, n_eff):
    """``F = ((RSS_ref - RSS_new) / k) / (RSS_new / (n_eff - p))`` against ``F(k, n_eff - p)`` (Bates & Watts
    1988, sec. 3.5), by hand with scipy.stats.f."""
    dof = n_eff - p
    f = ((rss_ref - rss_new) / k) / (rss_new / dof)
    assert vd.f_pvalue(rss_ref, rss_new, k, p, n_eff) == pytest.approx(float(stats.f.sf(f, k, dof)), rel=1e-12)


def test_f_pvalue_on_both_sides_of_alpha():
    """k = 1, dof = 194: the 1 % critical value F* = stats.f.isf(0.01, 1, 194); RSS ratios giving 0.9 F* and
    1.1 F* fall on the two sides of ALPHA."""
    k, p, n_eff = 1, 6, 200.0
    dof = n_eff - p
    f_crit = float(stats.f.isf(vd.ALPHA, k, dof))
    for factor, below in ((0.9, False), (1.1, True)):
        rss_new = 1.0
        rss_ref = rss_new * (1.0 + factor * f_crit * k / dof)
        assert (vd.f_pvalue(rss_ref, rss_new, k, p, n_eff) < vd.ALPHA) == below, factor


# --- closes: the tolerance is the larger of the two ----------------------------------------------------------------
def test_closes_takes_the_larger_of_tolerance_and_close_fraction():
    """close_fraction 0.15 of sqrt(excess0) = 1e-5 gives 1.5e-6; against a test tolerance of 3e-6 (larger) and of
    1e-6 (smaller), an excess between the two closes and one above both does not; every axis must close."""
    s = DiagnoseSettings()
    frac = s.close_fraction * math.sqrt(1e-10)
    assert frac == pytest.approx(1.5e-6)
    e0 = {"x": 1e-10}
    # tolerance above the fraction: 2e-6 lies between them
    assert vd.closes({"x": 2.0e-6}, e0, {"x": 3e-6}, s)
    assert not vd.closes({"x": 3.2e-6}, e0, {"x": 3e-6}, s)
    # tolerance below the fraction: 1.2e-6 lies between them
    assert vd.closes({"x": 1.2e-6}, e0, {"x": 1e-6}, s)
    assert not vd.closes({"x": 1.6e-6}, e0, {"x": 1e-6}, s)
    # two axes, one closed and one not: not closed
    e2 = {"x": 1e-10, "y": 1e-10}
    assert not vd.closes({"x": 1e-7, "y": 4e-6}, e2, {"x": 3e-6, "y": 3e-6}, s)
    assert vd.closes({"x": 1e-7, "y": 2e-6}, e2, {"x": 3e-6, "y": 3e-6}, s)


# --- the first step's fractions ------------------------------------------------------------------------------------
def _ranked(frac, closes_gap, score=1.0):
    return {"effect": "constructed", "score": score, "gap_reduction": frac, "closes_gap": closes_gap,
            "significant": True, "n_params": 1, "_losses": np.ones(6), "params": {AXIS: {}}, "uncertainty": {}, "fits": {}}


def test_first_step_fractions_on_both_sides_of_their_thresholds():
    """One significant candidate scoring below the baseline (no runner-up, so never tentative):

    - closing the gap with ``min_gap_reduction`` (0.6) +- 0.01 of the excess power: explained above, partly below;
    - not closing it, ``MIN_PARTIAL`` (0.25) +- 0.01: partly explained above, nothing below.
    """
    s = DiagnoseSettings()
    base_held = 2.0 * ARCSEC  # 2 arcsec held-out RMS of the baseline; the candidate scores 1 arcsec
    g = s.min_gap_reduction
    above = vd.first_step([_ranked(g + 0.01, True)], base_held, s)
    below = vd.first_step([_ranked(g - 0.01, True)], base_held, s)
    assert above and above[0]["closes_gap"]
    assert below and not below[0]["closes_gap"]
    assert vd.first_step([_ranked(vd.MIN_PARTIAL + 0.01, False)], base_held, s)
    assert vd.first_step([_ranked(vd.MIN_PARTIAL - 0.01, False)], base_held, s) == []
    # a candidate scoring no better than the baseline is never a first step
    assert vd.first_step([_ranked(0.9, True, score=2.5)], base_held, s) == []


@pytest.mark.parametrize("frac, kept", [(vd.DOMINANT + 0.01, True), (vd.DOMINANT - 0.01, False)])
def test_keep_dominant_on_both_sides_of_dominant(frac, kept):
    """A lone tentative first step is kept only when it closes at least DOMINANT (0.8) of the gap."""
    steps = [{"tentative": True, "explained_fraction": frac}]
    assert bool(vd.keep_dominant(steps)) == kept
    assert vd.keep_dominant([{"tentative": False, "explained_fraction": frac}])  # not tentative: always kept
