"""The sweep's statistics (issue 22, point 4): percentiles only where the sample supports them, with intervals and
n; drivers only where a test over the whole family finds them; a 10-unit lot prints no p99.

Every threshold is recomputed here independently (a scan of ``scipy.stats.binom``, ``scipy.stats.spearmanr``,
closed forms), and every statistical assertion states its margin.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.stats import binom, spearmanr

from sins_sim.cli import main
from sins_sim.jobs.sweep.summary import (DRIVER_ALPHA, driver_tests, order_statistic_interval, quantile_n_required,
                                         quantile_summary, summarize)

ROOT = Path(__file__).resolve().parents[1]
SCEN = ROOT / "scenarios"
QUANTILES = {"p50": 0.50, "p95": 0.95, "p99": 0.99}


def _binomial_n_required(q: float, tail: float = 0.025) -> int:
    """The fewest n for which some ranks 1 <= l < u <= n give P(B < l) <= tail and P(B >= u) <= tail,
    B ~ Binomial(n, q): a scan over n and over every pair of ranks (slow and obvious)."""
    for n in range(1, 2000):
        k = np.arange(1, n + 1)
        lower = binom.cdf(k - 1, n, q) <= tail  # X_(k) a lower bound
        upper = binom.sf(k - 1, n, q) <= tail   # X_(k) an upper bound
        if lower.any() and upper.any():  # then l < u: P(B < l) + P(B >= u) <= 0.05 rules out l >= u
            return n
    raise AssertionError("no n below 2000")


# --- percentiles ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("q", [0.5, 0.9, 0.95, 0.99])
def test_quantile_support_thresholds_are_the_binomial_ones(q):
    need = _binomial_n_required(q)
    assert quantile_n_required(q) == need
    assert order_statistic_interval(need - 1, q) is None
    for n in (need, need + 1, 3 * need):
        lo, hi = order_statistic_interval(n, q)
        # each tail at most 2.5 % and the ranks as tight as that allows (one rank more gives a tail above 2.5 %)
        assert binom.cdf(lo - 1, n, q) <= 0.025 < binom.cdf(lo, n, q)
        assert binom.sf(hi - 1, n, q) <= 0.025 < binom.sf(hi - 2, n, q)


def test_order_statistic_interval_covers_the_quantile_of_a_continuous_distribution():
    """Uniform samples (the q quantile is q): coverage >= 95 % at the smallest supported n of p95 and p99."""
    rng = np.random.default_rng(7)
    for q in (0.95, 0.99):
        n = quantile_n_required(q)
        lo, hi = order_statistic_interval(n, q)
        x = np.sort(rng.random((4000, n)), axis=1)
        covered = np.mean((x[:, lo - 1] <= q) & (q < x[:, hi - 1]))
        exact = 1.0 - binom.cdf(lo - 1, n, q) - binom.sf(hi - 1, n, q)
        # 4000 draws: the binomial standard error of a coverage near 0.96 is 0.003; 4 of them
        assert exact >= 0.95 and abs(covered - exact) < 4 * np.sqrt(exact * (1 - exact) / 4000)


def test_ten_values_give_a_median_but_no_p95_or_p99():
    x = np.random.default_rng(3).lognormal(size=10)
    s = quantile_summary(x)
    assert s["n"] == 10
    assert s["p95"] == {"supported": False, "n_required": _binomial_n_required(0.95), "n": 10}
    assert s["p99"] == {"supported": False, "n_required": _binomial_n_required(0.99), "n": 10}
    p50 = s["p50"]
    assert p50["supported"] and p50["value"] == np.percentile(x, 50) and p50["n"] == 10
    lo, hi = order_statistic_interval(10, 0.5)
    assert p50["ci95_order_statistic"] == [np.sort(x)[lo - 1], np.sort(x)[hi - 1]]
    assert p50["ci95"][0] <= p50["value"] <= p50["ci95"][1]
    assert quantile_summary([np.nan, np.inf]) is None
    assert quantile_summary([1.0, 2.0, np.nan, 3.0])["n"] == 3  # NaN and inf are left out of n


def test_bootstrap_interval_holds_the_estimate_narrows_with_n_and_matches_the_median_closed_form():
    rng = np.random.default_rng(11)
    widths = {}
    for n in (400, 1600, 6400):
        x = rng.standard_normal(n)
        s = quantile_summary(x)
        for key, q in QUANTILES.items():
            e = s[key]
            if not e["supported"]:
                assert n < quantile_n_required(q)
                continue
            assert e["ci95"][0] <= e["value"] <= e["ci95"][1]
            widths.setdefault(key, []).append(e["ci95"][1] - e["ci95"][0])
        # the median of N(0, 1): standard error sqrt(pi / (2 n)) (the asymptotic variance 1 / (4 n f(0)^2));
        # the bootstrap half-width within 25 % of 1.96 of them (the percentile bootstrap of a median is
        # discrete: its width moves by whole gaps between order statistics, about 10 % at n = 400)
        half = 0.5 * (s["p50"]["ci95"][1] - s["p50"]["ci95"][0])
        assert half == pytest.approx(1.96 * np.sqrt(np.pi / (2 * n)), rel=0.25)
    # four times the units: the interval about halves (1 / sqrt(4)); below 0.75 of the previous width
    for key, w in widths.items():
        assert all(b < 0.75 * a for a, b in zip(w, w[1:])), (key, w)
    assert [len(w) for w in widths.values()] == [3, 3, 3]  # p99 is supported from 368 values: all three n


# --- drivers: synthetic tables ------------------------------------------------------------------------------------
FILTERS = ("ideal", "eliminator", "correcting")
METRICS = ("horizontal_position_error_m_final", "velocity_error_m_s_final", "attitude_error_arcsec_rms_total")


def _table(rng, n_units: int, n_params: int, driver=None, dummy: bool = False) -> pd.DataFrame:
    """Two scenarios over the same units; metrics independent of every parameter except ``driver`` (the
    correcting filter's position error = exp(parameter) + noise, in both scenarios). One parameter is a
    two-value grid (ties), one metric column has a diverged unit (NaN)."""
    x = rng.standard_normal((n_units, n_params))
    x[:, 1] = np.where(np.arange(n_units) % 2, 30.0, -10.0)
    rows = []
    for scenario in ("a", "b"):
        for u in range(n_units):
            row = {"scenario": scenario, "unit": u, **{f"param.k{i}": x[u, i] for i in range(n_params)}}
            for f in FILTERS:
                row[f"{f}.status"] = "ok"
                for m in METRICS:
                    row[f"{f}.{m}"] = rng.lognormal()
            if driver is not None:
                row["correcting.horizontal_position_error_m_final"] = np.exp(x[u, driver]) + 0.3 * rng.random()
            rows.append(row)
    t = pd.DataFrame(rows)
    t.loc[3, "eliminator.velocity_error_m_s_final"] = np.nan
    if dummy:
        d = rng.standard_normal(n_units)
        t["param.dummy"] = d[t["unit"].to_numpy()]
    return t


def test_reported_rho_is_spearmanr_and_one_test_is_its_own_adjustment():
    rng = np.random.default_rng(5)
    t = _table(rng, 40, 4, driver=0)
    tests = driver_tests(t, ["a", "b"], metrics=METRICS)
    # 2 scenarios x 3 metrics x 3 filters x 4 parameters, none constant
    assert len(tests) == 72
    for rec in tests:
        sub = t[t["scenario"] == rec["scenario"]]
        x, y = sub[f"param.{rec['parameter']}"].to_numpy(), sub[f"{rec['filter']}.{rec['metric']}"].to_numpy()
        ok = np.isfinite(y)
        r = spearmanr(x[ok], y[ok])
        assert rec["n"] == ok.sum() and rec["spearman"] == pytest.approx(r.statistic, abs=1e-12)
        assert rec["p"] <= rec["p_adjusted"] <= 1.0
        # the unadjusted permutation p-value against spearmanr's t approximation where both are moderate
        # (0.02-0.5: the t approximation is within 15 % there; 4999 permutations add a standard error below 10 %)
        if 0.02 < r.pvalue < 0.5:
            assert rec["p"] == pytest.approx(r.pvalue, rel=0.3)
    assert {(r["scenario"], r["parameter"]) for r in tests if r["significant"]} == {("a", "k0"), ("b", "k0")}
    # a family of one: the adjusted p-value is the test's own
    one = driver_tests(t[t["scenario"] == "a"][["scenario", "unit", "param.k2", "ideal.status",
                                                  "ideal.velocity_error_m_s_final"]], ["a"], metrics=METRICS)
    assert len(one) == 1 and one[0]["p_adjusted"] == one[0]["p"]


def test_a_constant_metric_is_not_tested():
    rng = np.random.default_rng(2)
    t = _table(rng, 20, 3)
    t["ideal.horizontal_position_error_m_final"] = 1.5
    tests = driver_tests(t, ["a", "b"], metrics=METRICS)
    assert not [r for r in tests if r["filter"] == "ideal" and r["metric"] == METRICS[0]]
    assert len(tests) == 2 * (3 * 3 - 1) * 3


@pytest.mark.parametrize("n_units", [10, 50])
def test_no_parameter_is_reported_on_tables_without_a_driver_beyond_the_family_wise_rate(n_units):
    """200 tables where no parameter acts (the complete null; the issue's 10-unit lot and a 50-unit one).

    The step-down maxT controls the chance of reporting any parameter at 0.05. If it were exactly 0.05 the
    count of tables with a report would be Binomial(200, 0.05): mean 10, and above 20 with probability 0.0012.
    """
    rng = np.random.default_rng(1000 + n_units)
    alarms = 0
    for _ in range(200):
        tests = driver_tests(_table(rng, n_units, 8), ["a", "b"], metrics=METRICS, permutations=999,
                             seed=int(rng.integers(2 ** 31)))
        assert len(tests) == 2 * 9 * 8
        alarms += any(r["significant"] for r in tests)
    assert alarms <= binom.ppf(0.998, 200, DRIVER_ALPHA) == 20


def test_a_genuine_driver_is_reported_and_a_dummy_parameter_is_not():
    """200 tables of 30 units with one parameter acting (exp(k0) + noise, rho about 0.9) and a dummy one.

    Power: the driver is found in every table (its maxT statistic is about 4.8 against a 5 % critical value
    near 3.3). The dummy: reported in at most as many tables as the family-wise rate allows (Binomial(200,
    0.05) above 20 with probability 0.0012); the strong control of the maxT procedure holds whatever the
    other parameters do.
    """
    rng = np.random.default_rng(99)
    dummy = found = 0
    for _ in range(200):
        t = _table(rng, 30, 6, driver=0, dummy=True)
        tests = driver_tests(t, ["a", "b"], metrics=METRICS, permutations=999, seed=int(rng.integers(2 ** 31)))
        sig = {(r["scenario"], r["filter"], r["metric"], r["parameter"]) for r in tests if r["significant"]}
        found += {("a", "correcting", METRICS[0], "k0"), ("b", "correcting", METRICS[0], "k0")} <= sig
        dummy += any(p == "dummy" for *_, p in sig)
    assert found == 200
    assert dummy <= 20


# --- a real sweep -------------------------------------------------------------------------------------------------
LOT = f"""
name: lot10
seed: 8
units: 10
scenarios:
  - {{path: {SCEN / 'stationary.yaml'}, duration_s: 1.5}}
population:
  f0_ppm: {{width: 2000}}
  k3_percent: {{distribution: uniform, width: 10}}
  k4_percent: {{width: 10}}
  temperature_k: {{distribution: uniform, width: 20}}
  temperature_coefficient_ppm_per_k: {{mean: -30, width: 5}}
"""


@pytest.fixture(scope="module")
def lot10(tmp_path_factory):
    """A 10-unit lot through ``sins-sim sweep`` (one worker process)."""
    import contextlib
    import io

    d = tmp_path_factory.mktemp("lot10")
    (d / "lot10.yaml").write_text(LOT)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        assert main(["sweep", str(d / "lot10.yaml"), "--out", str(d / "out"), "--workers", "1"]) == 0
    return d / "out", out.getvalue(), err.getvalue()


def test_a_ten_unit_lot_prints_and_stores_no_p95_or_p99(lot10):
    out, text, _ = lot10
    s = json.loads((out / "summary.json").read_text())
    need = _binomial_n_required(0.99)
    for block in [s["percentiles"], *(b["percentiles"] for b in s["by_scenario"].values())]:
        for per in block.values():
            for q in per.values():
                assert q["n"] <= 10 and "value" not in q["p99"] and "value" not in q["p95"]
                assert q["p99"] == {"supported": False, "n_required": need, "n": q["n"]}
    lines = text.splitlines()
    head = next(i for i, ln in enumerate(lines) if ln.startswith("scenario"))
    assert "p50 [95% CI]" in lines[head] and "p95" not in lines[head] and "p99" not in lines[head]
    assert any(ln.startswith("p99 not shown where n < 368 (n = 10 here)") for ln in lines)
    assert any(ln.startswith("p95 not shown where n < 72 (n = 10 here)") for ln in lines)
    # the table rows: the median with its interval, and n = 10
    rows = lines[head + 1:head + 5]
    x = pd.read_parquet(out / "runs.parquet")["correcting.horizontal_position_error_m_final"]
    corr = next(ln for ln in rows if ln.split()[1] == "correcting")
    assert corr.split()[2] == f"{np.percentile(x, 50):.3g}" and corr.split()[-1] == "10"
    # no significant driver at n = 10: said, not left out
    assert any("no significant driver at n = 10" in ln for ln in lines)


def test_progress_moves_per_run_and_says_what_happens_before_the_first(lot10):
    _, _, err = lot10
    frames = [f for f in err.replace("\r", "\n").splitlines() if "runs |" in f]
    assert any("starting a Dask cluster of 1 worker process" in f for f in frames)
    assert any("waiting for the first runs" in f for f in frames)
    counts = sorted({int(f.split(": ", 1)[1].split("/")[0]) for f in frames})
    # every finished task moves the bar by its runs (issue 26: several runs per task; batch_size's rule for 10
    # runs of well under 1 s each on one worker thread: at least 4 tasks, so tasks of 3, 3, 3 and 1 run)
    from sins_sim.jobs.sweep.job import _batches, prepare_sweep

    sizes = [len(b) for b in _batches(prepare_sweep(lot10[0] / "sweep.yaml")[1], 1, None)]
    assert sorted(sizes, reverse=True) == [3, 3, 3, 1]
    assert counts[0] == 0 and counts[-1] == 10 and len(counts) == len(sizes) + 1
    assert sorted(b - a for a, b in zip(counts, counts[1:])) == sorted(sizes)
    assert any("runs/min" in f for f in frames if f.split(": ", 1)[1].startswith("10/10"))


def test_a_dummy_parameter_injected_into_a_real_sweep_is_never_reported(lot10):
    """The 10-unit lot's table with a random dummy parameter column (one draw per unit), 100 seeds: the dummy
    is reported in no more tables than the family-wise rate allows (Binomial(100, 0.05) above 12 with
    probability 0.0015), and no parameter of this lot is significant at n = 10."""
    out, _, _ = lot10
    table = pd.read_parquet(out / "runs.parquet")
    rng = np.random.default_rng(22)
    reported = 0
    for _ in range(100):
        t = table.copy()
        t["param.dummy"] = rng.standard_normal(10)[t["unit"].to_numpy()]
        tests = driver_tests(t, ["stationary"], permutations=999, seed=int(rng.integers(2 ** 31)))
        assert any(r["parameter"] == "dummy" for r in tests)
        reported += any(r["significant"] and r["parameter"] == "dummy" for r in tests)
    assert reported <= binom.ppf(0.998, 100, DRIVER_ALPHA) == 12
    s = summarize(table, [], ["stationary"])
    assert all(not d["significant"] for per in s["drivers"]["stationary"].values() for d in per.values())
