"""The known-trajectory fit under correlated noise: its twin's noise terms and its sigmas under a rate random walk.

The logs are made here as arrays, independently of the code under test: a unit rocked about all three axes (rates
``A sin(2 pi f t)``, three incommensurate frequencies, so every scale factor is excited apart from the bias), its
increments ``x_true + b dt + E x_true + n`` (Groves 2013, sec. 4.4.6) with white rate noise of density ``N``
(per-sample sigma ``N sqrt(dt)`` of the angle) and a rate random walk ``K`` (steps of ``K sqrt(dt)`` per sample, Allan
variance ``K^2 tau / 3``: IEEE Std 952-1997, Annex C).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import binom, chi2

from sins_sim.navigation.truth_fit import fit_against_truth
from sins_sim.units import DEG, DEG_PER_H, MICRO_G

DT = 0.01
T_S = 600.0
N_G = 0.01 * DEG / 60.0                      # 0.01 deg/sqrt(h)
#: The random walk crosses the white noise at 20 s (N^2 / tau = K^2 tau / 3): over 600 s it moves the bias by
#: K sqrt(T / 3) = 0.025 deg/h, about 6 times the white noise's share of a constant's sigma, N / sqrt(T)
K_G = math.sqrt(3.0) * N_G / 20.0
VRW = 30.0 * MICRO_G
B_G = np.array([0.5, -0.3, 0.8]) * DEG_PER_H
E_G = np.diag([50e-6, -30e-6, 80e-6])
SEEDS = 40


def _log(seed):
    rng = np.random.default_rng(seed)
    n = int(T_S / DT)
    t = np.arange(1, n + 1) * DT
    w = 2.0 * math.pi
    th = np.column_stack([0.3 * np.sin(w * 0.05 * t), 0.2 * np.sin(w * 0.07 * t + 1.0),
                          0.4 * np.sin(w * 0.03 * t + 2.0)]) * DT
    v = np.column_stack([2.0 * np.sin(w * 0.04 * t), 1.5 * np.sin(w * 0.06 * t + 1.0),
                         -9.8 + np.sin(w * 0.02 * t)]) * DT
    noise = (rng.standard_normal((n, 3)) * N_G * math.sqrt(DT)
             + np.cumsum(rng.standard_normal((n, 3)), axis=0) * K_G * math.sqrt(DT) * DT)
    meas = th + B_G * DT + th @ E_G.T + noise
    vm = v + rng.standard_normal((n, 3)) * VRW * math.sqrt(DT)
    return fit_against_truth(DT, {"gyro": meas, "accelerometer": vm}, {"gyro": th, "accelerometer": v})


def test_sigmas_cover_under_a_rate_random_walk_where_the_white_noise_sigmas_did_not():
    z_new, z_old, z_sf = [], [], []
    fits = [_log(seed) for seed in range(SEEDS)]
    for fit in fits:
        err = fit.bias["gyro"] - B_G
        z_new += list(err / fit.bias_sigma["gyro"])
        z_old += list(err / fit.ols_sigma["gyro"]["bias"])
        z_sf += list((np.diag(fit.e["gyro"]) - np.diag(E_G)) / np.diag(fit.e_sigma["gyro"]))
    z_new, z_old, z_sf = (np.abs(np.array(z)) for z in (z_new, z_old, z_sf))
    m = z_new.size                                          # 120 independent z (40 seeds, 3 axes)
    # with honest sigmas the number inside +-1.96 is Binomial(m, 0.95): at least 90 % of them (108 of 120) fails
    # with a chance of binom.cdf(107, 120, 0.95) = 0.7 %. The white-noise sigmas (ordinary least squares on the
    # block sums) hold the walk only through the residuals' scatter about the fit, not its share in the bias,
    # K^2 T / 3 against N^2 / T: 30 times in standard deviation here, less what the scatter takes in; measured, the
    # bias's z has an RMS of 6. Inside +-1.96 then with a chance of about 2 Phi(1.96 / 6) - 1 = 0.26: 60 % of them
    # or more has a chance binom.sf(72, 120, 0.26) below 1e-13
    need = math.ceil(0.9 * m)
    assert binom.cdf(need - 1, m, 0.95) < 0.01
    assert np.sum(z_new < 1.96) >= need, np.sort(z_new)[-15:]
    assert np.sum(z_old < 1.96) <= 0.6 * m, np.sum(z_old < 1.96)
    assert np.sum(z_sf < 1.96) >= need, np.sort(z_sf)[-15:]
    # not bought by sigmas far too large: the mean z^2 of honest sigmas is chi2(m) / m, below its 99.9 % quantile,
    # and with the walk's level at its one-sided 84 % likelihood bound (RHO_LEVEL; conservative) not below a third
    assert np.mean(z_new ** 2) <= chi2.ppf(0.999, m) / m
    assert np.mean(z_new ** 2) >= 1.0 / 3.0, np.mean(z_new ** 2)
    # the residual's noise is the log's: white within 5 % (its Allan fit reads N off thousands of clusters) and the
    # random walk determined on some axes (it crosses the white noise at 20 s, within the 60 s of reliable taus)
    d = fits[0].to_dict()["gyro"]["noise"]
    for ax in "xyz":
        assert abs(d[ax]["arw_deg_rt_h"]["value"] / 0.01 - 1.0) < 0.05, d[ax]
    rrw = [d[ax]["rrw_deg_h_rt_h"]["value"] / (K_G * 60.0 / DEG_PER_H) for ax in "xyz"]
    assert all(0.0 < r < 2.0 for r in rrw), rrw
