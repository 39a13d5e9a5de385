"""A close call is said as one (issue 39, items 2 and 3).

- The held-out test that ranks two candidates (``verdict.dm_test``): its Newey-West variance against
  closed forms, and its false-preference rate on the project's own generator over 40 dither-only
  recordings of a drive lag, where a readout delay is its near-degenerate rival (slow).
- Two candidates the held-out test cannot tell apart are reported together (``discriminate.close_rivals``).
- A candidate closing at least ``MIN_PARTIAL`` of the gap in-sample but failing the held-out test is named by
  a verdict ``unknown``, with the recording length that would confirm it (``verdict.unconfirmed``).

The verdict rules are exercised on hand-made candidates (what ``explain`` and ``assess`` produce), on both
sides of each threshold.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from sins_sim.identification.calibration import binomial_margin, false_preference
from sins_sim.identification.diagnose import DiagnoseSettings
from sins_sim.identification.discriminate import close_rivals
from sins_sim.identification.plausibility import candidate_plausibility
from sins_sim.identification.verdict import (AHEAD_ALPHA, ALPHA, CONFIRM_POWER, MIN_PARTIAL, confirm_duration,
                                             dm_pvalue, dm_test, first_step, give_verdict, hac_variance,
                                             nw_bandwidth)
from sins_sim.jobs.recording_jobs import format_diagnosis
from sins_sim.units import ARCSEC

from test_diagnose_verdict import _cand  # noqa: E402  (hand-made candidates)


# --- the held-out test's variance ------------------------------------------------------------------------
def test_newey_west_variance_against_its_sum_written_out():
    """``hac_variance`` is ``g0 + 2 sum_j (1 - j/(L+1)) g_j`` (Newey & West 1987, eq. 2), each autocovariance
    over ``m`` (not ``m - j``): checked against the sum written out with numpy on a fixed sequence (to
    rounding, 1e-12 relative); with ``L = 0`` terms it is the biased variance ``np.var``."""
    d = np.array([0.3, -0.1, 0.4, 0.2, -0.5, 0.1, 0.0, 0.6, -0.2, 0.3])
    m, e = d.size, d - d.mean()
    g = [float(np.sum(e[j:] * e[:m - j])) / m for j in range(3)]
    assert hac_variance(d, 2) == pytest.approx(g[0] + 2 * (2 / 3) * g[1] + 2 * (1 / 3) * g[2], rel=1e-12)
    assert hac_variance(d, 0) == pytest.approx(np.var(d), rel=1e-12)
    # the bandwidth rule floor(4 (m/100)^(2/9)) (Newey & West 1994): 2 lags at m = 10 and 20, 3 at 43
    assert [nw_bandwidth(m) for m in (10, 20, 43)] == [2, 2, 3]


def test_positively_correlated_differentials_lower_the_statistic():
    """A loss differential alternating slowly (runs of three equal values) carries fewer independent blocks than
    its count: the Newey-West variance of its mean is larger than the plain ``var / m``, so the statistic with
    the same mean is smaller and the p-value larger than the independent-blocks one. For alternating signs
    (negative correlation) the reverse."""
    runs = np.repeat([0.3, -0.1, 0.4, 0.2], 3)[:12] + 0.05
    flip = np.array([0.3, -0.1] * 6) + 0.05
    for d, wider in ((runs, True), (flip, False)):
        plain = float(np.var(d))
        assert (hac_variance(d, nw_bandwidth(d.size)) > plain) is wider
    lr = np.exp(runs)
    res = dm_test(lr, np.ones_like(lr))
    m, h = res["m"], res["lags"] + 1
    hln = math.sqrt((m + 1 - 2 * h + h * (h - 1) / m) / m)
    expected = runs.mean() / math.sqrt(hac_variance(runs, res["lags"]) / m) * hln
    assert res["statistic"] == pytest.approx(expected, rel=1e-12)
    assert res["p"] == pytest.approx(stats.t.sf(expected, m - 1), rel=1e-12)


@pytest.mark.slow
def test_near_degenerate_pair_false_preference_rate_is_within_the_level():
    """40 one-second dither-only recordings of a drive lag (``piezo_lag``, 50-300 us, the unit drawn as
    ``diagnose-eval --hard`` draws it): how often the held-out test declares the readout delay better at
    ``AHEAD_ALPHA`` (5 %). A test of size at most 5 % gives a count ``X <= Binomial(40, 0.05)``; the count
    allowed is that law's 99 % quantile, 6 (``P(X > 6) = 0.003``), so a well-sized test fails here with
    probability below 1 %, and one of size 20 % (mean 8) passes with probability 0.31 only.

    Before issue 39 the count was 2 (the true lag's fit stopped short by the candidate budget, 17 sigma
    from its optimum); with the contenders' fits finished it is 1 (p = 0.034, a differential of 1e-3 per block,
    within the noise). About 40 diagnoses of 1 s: minutes, hence slow."""
    res = false_preference("piezo_lag", "readout_delay", range(40), "stationary", duration_s=1.0,
                           level=AHEAD_ALPHA, settings=DiagnoseSettings(threads=2))
    allowed = binomial_margin(40, AHEAD_ALPHA, 0.99)
    assert allowed == 6
    assert res["n"] == 40
    assert res["false"] <= allowed, [r for r in res["rows"] if r["p_wrong"] < AHEAD_ALPHA]


# --- a pair that explains alike is reported as such -------------------------------------------------------
def _pair(scatter, shift, frac=0.5):
    """The named candidate and a rival whose held-out block losses scatter by ``scatter`` (log) around its own,
    shifted by ``shift`` (log): the rival is that much worse on average."""
    rng = np.random.default_rng(11)
    base = np.exp(rng.normal(0.0, 1.0, 10))
    best = _cand("piezo_lag", 1, base, 0.30)
    rival = _cand("readout_delay", 1, base * np.exp(shift + rng.normal(0.0, scatter, 10)), 0.301)
    for c in (best, rival):
        c["gap_reduction"] = frac
    return best, rival


@pytest.mark.parametrize("status", ["explained", "partly explained"])
def test_a_rival_the_held_out_test_cannot_put_behind_is_reported_with_the_named_effect(status):
    """Named effect and rival, both significant, the rival closing 0.5 of the gap (>= MIN_PARTIAL, not the gap):
    with block losses within 5 % of each other the held-out test does not put the rival behind (p >= 5 %): it is
    a close rival, for ``explained`` and for ``partly explained``. With the rival's losses 30 % higher in every
    block (p far below 5 %), it is not; nor when it closes less than MIN_PARTIAL."""
    settings = DiagnoseSettings()
    verdict = {"status": status, "effect": "piezo_lag", "effects": [{"effect": "piezo_lag"}]}
    best, rival = _pair(0.05, 0.0)
    assert dm_pvalue(rival["_losses"], best["_losses"]) >= AHEAD_ALPHA
    assert close_rivals(verdict, [best, rival], settings) == [rival]
    best, worse = _pair(0.05, math.log(1.3))
    assert dm_pvalue(worse["_losses"], best["_losses"]) < AHEAD_ALPHA
    assert close_rivals(verdict, [best, worse], settings) == []
    best, small = _pair(0.05, 0.0, frac=0.99 * MIN_PARTIAL)
    assert close_rivals(verdict, [best, small], settings) == []
    assert close_rivals({**verdict, "status": "unknown"}, [best, rival], settings) == []


def test_a_typical_parameter_value_is_no_evidence():
    """Plausibility only sets aside values no unit has (a range end, an effect switched on where there is no
    gap); inside the declared range a typical drive lag (150 us) and an unusual one (3 us) are alike plausible,
    so the ranking between two such candidates is by the held-out score alone: the unusual one, scoring better,
    comes first."""
    floors = {"x": {"floor_rad": 0.3 * ARCSEC}}
    tol = {"x": 0.05 * ARCSEC}
    ref = {"x": SimpleNamespace(rms=0.8 * ARCSEC)}

    def cand(tau, score):
        c = _cand("piezo_lag", 1, np.ones(10), score)
        c.update(params={"x": {"tau_s": tau}}, uncertainty={"x": {"tau_s": 0.01 * tau}},
                 fits={"x": SimpleNamespace(rms=0.35 * ARCSEC)}, gap_reduction=0.9, closes_gap=True)
        c["plausibility"] = candidate_plausibility(c, ref, floors, tol, ["x"], ["x"])
        return c

    typical, unusual = cand(1.5e-4, 0.40), cand(3e-6, 0.39)
    assert typical["plausibility"]["plausible"] and unusual["plausibility"]["plausible"]
    steps = first_step([typical, unusual], 0.8, DiagnoseSettings())
    assert steps and steps[0]["params"] == {"x": {"tau_s": 3e-6}}


# --- in-sample closure not confirmed on held-out data ------------------------------------------------------
FITS = {"x": SimpleNamespace(heldout_rms=0.5 * ARCSEC, rms=0.5 * ARCSEC)}


def _unconfirmed_case(frac, p, m=10):
    """A candidate closing ``frac`` of the gap in-sample with held-out p-value ``p`` (and the statistic that
    gives it on ``m`` blocks), not significant, so the verdict is ``unknown``."""
    c = _cand("piezo_lag", 1, np.ones(m), 0.45, significant=False)
    t = float(stats.t.isf(p, m - 1))
    c.update(gap_reduction=frac, p_heldout=p, t_heldout=t, m_heldout=m, params={"x": {"tau_s": 1.12e-4}},
             uncertainty={"x": {"tau_s": 4e-6}})
    return c


@pytest.mark.parametrize("frac, p, named", [(0.89, 0.09, True), (1.01 * MIN_PARTIAL, 1.01 * ALPHA, True),
                                            (0.99 * MIN_PARTIAL, 0.09, False), (0.89, 0.99 * ALPHA, False)])
def test_unknown_names_what_closes_the_gap_in_sample_only(frac, p, named):
    """Both sides of both thresholds: in-sample closure at least MIN_PARTIAL (0.25) and held-out p at least
    ALPHA (0.01). Named: the message says the fraction and the p-value; the verdict stays ``unknown`` with
    explained fraction 0. Below 0.25, nothing is named; with p below the level the held-out test confirms it
    (the verdict's other rules decide; here ``unknown`` still, as the candidate is not marked significant, but
    it is no in-sample-only case)."""
    c = _unconfirmed_case(frac, p)
    v = give_verdict(FITS, ["x"], [c], DiagnoseSettings(), steps=[], duration_s=1.0)
    assert v["status"] == "unknown" and v["explained_fraction"] == 0.0
    u = v["unconfirmed"]
    if not named:
        assert u is None
        return
    assert u["effect"] == "piezo_lag" and u["in_sample_fraction"] == pytest.approx(frac)
    assert f"piezo_lag closes {frac:.2f} in-sample, not confirmed on held-out data (p = {p:.2g})" in u["message"]
    assert u["confirm_duration_s"] > 1.0 and u["power"] == CONFIRM_POWER
    # the printed summary carries it (what `sins-sim diagnose` prints)
    js = {"verdict": v, "gap": {"significant": True, "axis": "x"}, "candidates": []}
    assert u["message"] in format_diagnosis(js)


def test_the_issue_case_is_worded_as_the_issue_asks():
    v = give_verdict(FITS, ["x"], [_unconfirmed_case(0.89, 0.09)], DiagnoseSettings(), steps=[], duration_s=1.0)
    assert v["unconfirmed"]["message"].startswith("piezo_lag closes 0.89 in-sample, not confirmed on held-out "
                                                  "data (p = 0.09)")


def test_confirming_length_follows_the_square_root_law():
    """``n' = n ((c + z_power) / t_obs)^2``, ``c`` the one-sided t_{m-1} critical value at ALPHA: a statistic
    already at ``c + z_power`` needs the recording's own length; half that statistic four times it; none for a
    statistic at or below 0 (the held-out data show no improvement)."""
    m, n = 10, 2.0
    target = float(stats.t.isf(ALPHA, m - 1) + stats.norm.ppf(CONFIRM_POWER))
    assert confirm_duration(target, m, n) == pytest.approx(n, rel=1e-12)
    assert confirm_duration(0.5 * target, m, n) == pytest.approx(4.0 * n, rel=1e-12)
    assert confirm_duration(0.0, m, n) is None and confirm_duration(-1.0, m, n) is None


def test_confirming_length_gives_the_stated_power_on_simulated_differentials():
    """An independent check of the rule on the test itself: held-out differentials simulated as white noise
    around a fixed mean (an effect of fixed size; ten blocks whose noise falls as ``1 / sqrt(length)``), the
    statistic at 1 s taken as its expectation: the mean over the standard error the Newey-West variance gives on
    average (for a demeaned white sequence ``E[g_0] = (m-1)/m s^2`` and ``E[g_j] = -(m-j)/m^2 s^2``, so
    ``E[S] = 0.727 s^2`` at ``m = 10``, ``L = 2``), HLN-corrected. At the predicted length the test rejects at
    ALPHA in CONFIRM_POWER of the draws to within 0.05: four standard errors of a proportion over 4000 draws
    (0.025) and as much again for the rule's normal approximation of the statistic, whose variance estimate has
    few degrees of freedom (not derived; the point is a length of the right size, not a second decimal)."""
    rng = np.random.default_rng(5)
    m, mu, sd = 10, 0.02, 0.1
    draws = 4000
    lags = nw_bandwidth(m)
    h = lags + 1
    mean_s = (m - 1) / m - sum(2 * (1 - j / (lags + 1)) * (m - j) / m ** 2 for j in range(1, lags + 1))
    t_exp = mu / math.sqrt(mean_s * sd ** 2 / m) * math.sqrt((m + 1 - 2 * h + h * (h - 1) / m) / m)
    need = confirm_duration(t_exp, m, 1.0)
    s = sd / math.sqrt(need)
    hits = sum(dm_test(np.exp(rng.normal(mu, s, m)), np.ones(m))["p"] < ALPHA for _ in range(draws))
    assert abs(hits / draws - CONFIRM_POWER) < 0.05, (need, hits / draws)


# --- a scale-factor error on a table without the site can be the Earth's rate -----------------------------
def test_a_scale_error_on_a_table_without_site_is_named_beside_the_earth_rate():
    """A table turning at 10 deg/s on axes x, y, z (its angle on them ``theta t_i``, ``t = (0.6, 0, 0.8)``). A
    scale-factor error ``e = r / theta'`` on x and z is the steady rate ``r t_i``: with ``r`` = 0.8 of the Earth's
    rate, the recording cannot tell it from the Earth's rate along the table axis, so ``earth_rate`` joins the
    alternatives and the finding gives the implied rates (``e_i theta'_i``, to rounding); with ``r`` = 3 Earth
    rates, 1e-9 of sigma, it cannot be the Earth's: unchanged; with the site in the header: unchanged."""
    from sins_sim.earth import EARTH_RATE_RAD_S
    from sins_sim.identification.steady_rate import table_scale_as_earth
    from sins_sim.units import DEG, DEG_PER_H

    t = np.arange(7201) / 7200.0
    tvec = {"x": 0.6, "y": 0.0, "z": 0.8}
    rate = 10.0 * DEG
    sins = np.column_stack([rate * t * tvec[a] for a in "xyz"])

    def rec(site=None):
        return SimpleNamespace(site=site, sins_angle=sins, duration_s=1.0, axes=("x", "y", "z"),
                               axis_index=lambda a: "xyz".index(a))

    def verdict(r):
        e = r / rate
        return {"status": "explained", "effect": "scale_factor", "alternatives": [],
                "effects": [{"effect": "scale_factor", "params": {"x": {"error": e}, "z": {"error": e}},
                             "uncertainty": {"x": {"error": 1e-9 * e}, "z": {"error": 1e-9 * e}}}]}

    v = table_scale_as_earth(rec(), verdict(0.8 * EARTH_RATE_RAD_S))
    assert v["alternatives"] == ["earth_rate"] and v["steady_rate"]["finding"] == "earth_rate"
    for a in ("x", "z"):
        assert v["steady_rate"]["rate_deg_h"][a] == pytest.approx(0.8 * EARTH_RATE_RAD_S * tvec[a] / DEG_PER_H,
                                                                  rel=1e-9)
    assert "give the site" in v["steady_rate"]["message"]
    big = verdict(3.0 * EARTH_RATE_RAD_S)
    assert table_scale_as_earth(rec(), big) is big
    assert table_scale_as_earth(rec({"latitude_deg": 50.0}), verdict(0.8 * EARTH_RATE_RAD_S))["alternatives"] == []
