"""``sins-sim identify-eval``'s new classes: the logs it writes carry the withheld effects at their stated sizes,
two-effect classes are scored as stated, and one moving case is judged end to end.

The written log (a semicolon CSV in deg/h and mg along right-forward-up) is read back through ``import-log`` into
the body's forward-right-down axes; a moving case's increments are compared with its truth file's exact increments
(:func:`sins_sim.simulation.external.ideal_increments`). The unit's errors are linear in the exact increments
(``x_meas = x + b dt + E x + n``, Groves 2013, sec. 4.4.6) with white noise ``n``, so each effect's coefficient is
an ordinary least-squares fit beside the bias and error-matrix columns, normal about its truth with the fit's own
sigma ``s^2 (A^T A)^-1`` (Draper and Smith 1998, sec. 2.6). Tolerance: ``|z| < 3.29`` (99.9 % two-sided).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import norm

from sins_sim.io.trajectory import read_trajectory
from sins_sim.jobs.identify_eval import (
    CLASSES,
    DESCRIPTION,
    GROUPS,
    identify_eval,
    right_verdict,
    truth_path_of,
    write_case,
)
from sins_sim.jobs.import_log import import_log, read_log_table
from sins_sim.models.motion import SampledTrajectory
from sins_sim.simulation.external import ideal_increments
from sins_sim.units import DEG_PER_H

Z999 = float(norm.isf(0.0005))       # 3.29: 99.9 % two-sided


def _read_back(tmp_path, cls, seed, minutes=1.0):
    log = tmp_path / f"{cls}.csv"
    truth = write_case(log, cls, seed, minutes)
    t, dth, dv, _ = read_log_table(_imported(log, tmp_path / f"{cls}.parquet"))
    return log, truth, t, dth, dv


def _imported(log, table):
    import_log(log, DESCRIPTION, table)
    return table


def _ols(y, cols):
    """Least squares of ``y`` on the columns: (coefficients, their sigmas)."""
    a = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    r = y - a @ coef
    s2 = float(r @ r) / (y.size - a.shape[1])
    return coef, np.sqrt(np.diag(s2 * np.linalg.inv(a.T @ a)))


def _ideal(log, t, stretch=1.0):
    truth = SampledTrajectory.from_data(read_trajectory(truth_path_of(log)))
    return ideal_increments(truth, t * stretch - truth.time_offset_s)


def test_the_asymmetry_written_is_recovered_from_the_file_against_the_truth(tmp_path):
    log, truth, t, dth, _ = _read_back(tmp_path, "sf_asymmetry", 0)
    th, _ = _ideal(log, t)
    ax, dt = truth["axis"], float(t[1] - t[0])
    # both signs about the axis: the asymmetry is apart from the scale factor
    assert th[:, ax].min() < 0.0 < th[:, ax].max()
    # x_meas - x = b dt + E_row x + (A / 2) |x_ax| + n on the asymmetric gyro's row
    coef, sig = _ols(dth[:, ax] - th[:, ax], [np.full(t.size, dt), th[:, 0], th[:, 1], th[:, 2], np.abs(th[:, ax])])
    a_ppm, s_ppm = 2.0 * coef[4] * 1e6, 2.0 * sig[4] * 1e6
    assert 50.0 <= truth["asymmetry_ppm"] <= 200.0
    assert abs(a_ppm - truth["asymmetry_ppm"]) < Z999 * s_ppm, (a_ppm, s_ppm, truth["asymmetry_ppm"])
    # and no asymmetry on the other gyros
    for other in {0, 1, 2} - {ax}:
        c, s = _ols(dth[:, other] - th[:, other], [np.full(t.size, dt), th[:, 0], th[:, 1], th[:, 2],
                                                   np.abs(th[:, other])])
        assert abs(c[4]) < Z999 * s[4], (other, c[4], s[4])


def test_the_clock_rate_written_is_recovered_from_the_file_against_the_truth(tmp_path):
    log, truth, t, dth, _ = _read_back(tmp_path, "clock_rate", 1)
    th, _ = _ideal(log, t)
    dt = float(t[1] - t[0])
    # every interval lasts dt (1 + kappa): to first order the increment gains kappa d/dk[x(t (1 + k))] at k = 0,
    # the derivative taken by a central difference of the exact increments over h = 1e-4 (its truncation
    # error h^2 |x'''| / 6 relative, 1e-9, and the neglected kappa^2 term 4e-9 of the increment: far below the
    # noise); one kappa common to the three gyros, each with its bias and error-matrix row
    h = 1e-4
    d = (_ideal(log, t, 1.0 + h)[0] - _ideal(log, t, 1.0 - h)[0]) / (2.0 * h)
    rows, y = [], []
    for i in range(3):
        block = np.zeros((t.size, 13))
        block[:, i] = dt
        block[:, 3 + 3 * i: 6 + 3 * i] = th
        block[:, 12] = d[:, i]
        rows.append(block)
        y.append(dth[:, i] - th[:, i])
    coef, sig = _ols(np.concatenate(y), [c for c in np.vstack(rows).T])
    kappa_ppm, s_ppm = coef[12] * 1e6, sig[12] * 1e6
    assert 15.0 <= truth["rate_error_ppm"] <= 60.0
    assert abs(kappa_ppm - truth["rate_error_ppm"]) < Z999 * s_ppm, (kappa_ppm, s_ppm, truth["rate_error_ppm"])


def test_a_moving_noise_burst_triples_one_gyros_noise_in_its_window(tmp_path):
    log, truth, t, dth, _ = _read_back(tmp_path, "moving_noise_burst", 2)
    th, _ = _ideal(log, t)
    ax, dt = truth["axis"], float(t[1] - t[0])
    coef, _ = _ols(dth[:, ax] - th[:, ax], [np.full(t.size, dt), th[:, 0], th[:, 1], th[:, 2]])
    r = dth[:, ax] - th[:, ax] - np.column_stack([np.full(t.size, dt), th]) @ coef
    inside = (t > truth["start_s"]) & (t <= truth["start_s"] + t[-1] / 5.0 - dt / 2)
    # variance ratio 9 (white noise tripled); each side's sample variance has relative sd sqrt(2 / m), m >= 1200
    # samples: the log ratio's sd at most sqrt(2 / 1200 + 2 / 4800) = 0.046, against ln 9 = 2.2
    ratio = float(np.var(r[inside]) / np.var(r[~inside]))
    assert abs(math.log(ratio) - math.log(9.0)) < Z999 * math.sqrt(2.0 / inside.sum() + 2.0 / (~inside).sum()), ratio
    sigma = truth["unit"]["sensors"]["gyro"]["arw_deg_rt_h"][0] * DEG_PER_H * 60.0 * math.sqrt(dt)
    assert abs(math.sqrt(np.var(r[~inside])) / sigma - 1.0) < Z999 / math.sqrt(2.0 * (~inside).sum())


def test_a_two_effect_log_carries_the_step_at_its_size_beside_the_sway(tmp_path):
    log = tmp_path / "two.csv"
    truth = write_case(log, "sway+bias_step", 0, 2.0)
    t, dth, _, _ = read_log_table(_imported(log, tmp_path / "two.parquet"))
    dt = float(t[1] - t[0])
    ax, t_s, size = truth["bias_step_axis"], truth["bias_step_time_s"], truth["bias_step_size_deg_h"] * DEG_PER_H
    assert truth["sway_axis"] != ax and 0.2 <= truth["sway_frequency_hz"] <= 0.8
    # the mean rate over W = 20 s after the step less that over W before: its size, with sd from the white noise
    # (2 sigma^2 / m) and the rate random walk K W(t) (two independent half-windows, each K^2 W / 3)
    w_s = 20.0
    rate = dth[:, ax] / dt
    after, before = (t > t_s) & (t <= t_s + w_s), (t > t_s - w_s) & (t <= t_s)
    g = truth["unit"]["sensors"]["gyro"]
    sigma = g["arw_deg_rt_h"][0] * DEG_PER_H * 60.0 / math.sqrt(dt)
    k = g["rrw_deg_h_rt_h"][0] * DEG_PER_H / 60.0
    m = int(min(after.sum(), before.sum()))
    sd = math.sqrt(2.0 * sigma ** 2 / m + 2.0 * k ** 2 * w_s / 3.0)
    assert abs(rate[after].mean() - rate[before].mean() - size) < Z999 * sd, (size / DEG_PER_H, sd / DEG_PER_H)
    assert size > 10.0 * sd          # the step is there, not noise


def test_two_effect_classes_are_right_only_when_explained_naming_both():
    both = {"status": "explained", "effect": "bias_step",
            "effects": [{"effect": "bias_step"}, {"effect": "base_motion_line"}]}
    assert right_verdict("sway+bias_step", both)
    one = {**both, "effects": [{"effect": "bias_step"}]}
    assert not right_verdict("sway+bias_step", one)
    extra = {**both, "effects": both["effects"] + [{"effect": "bias_drift"}]}
    assert not right_verdict("sway+bias_step", extra)
    assert not right_verdict("sway+bias_step", {**both, "status": "partly explained"})
    assert right_verdict("sf_asymmetry", {"status": "explained", "effect": "scale_factor_asymmetry", "effects": []})
    assert set(GROUPS["moving"]) | set(GROUPS["two"]) | set(GROUPS["rest"]) == set(CLASSES)


def test_an_asymmetry_case_is_judged_through_identify_truth_from_the_command(tmp_path, capsys):
    import json

    from sins_sim.cli import main

    out = tmp_path / "eval.json"
    assert main(["identify-eval", "--seeds", "0", "--classes", "sf_asymmetry", "--quiet", "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    (case,) = r["cases"]
    assert case["right"] and case["effects"] == ["scale_factor_asymmetry"], case
    assert r["accuracy"]["looked"] == {"sf_asymmetry": [1, 1]}
    assert "explained (scale_factor_asymmetry)" in capsys.readouterr().out
    assert main(["identify-eval", "--classes", "moving,nope"]) != 0
    assert "or the groups ['rest', 'two', 'moving'], got 'nope'" in capsys.readouterr().err
    with pytest.raises(ValueError, match="or the groups"):
        identify_eval((0,), classes=["nope"])


def test_a_sway_and_a_step_at_rest_are_judged_and_both_named():
    r = identify_eval((0,), minutes=3.0, classes=["sway+bias_step"])
    (case,) = r["cases"]
    assert case["status"] == "explained" and sorted(case["effects"]) == ["base_motion_line", "bias_step"], case
    assert case["right"] and r["accuracy"]["looked"] == {"sway+bias_step": [1, 1]}
