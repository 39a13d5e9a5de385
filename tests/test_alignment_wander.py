"""The coarse alignment's stated heading sigma under a rate random walk and a bias instability.

Gyrocompassing reads the window's mean east bias: ``psi_D = -mean(eps_E) / (Omega cos lat)`` (Titterton and Weston
2004, sec. 10.2.2). A rate random walk ``K`` started at the window's start has a mean of variance ``K^2 T / 3``; a
first-order Gauss-Markov process of variance ``q`` and correlation time ``tau`` a mean of variance
``q 2 (x - 1 + e^-x) / x^2`` with ``x = T / tau`` (Brown and Hwang 2012, ch. 2). Both are checked here against an
independent simulation, then the stated sigma's coverage over 60 seeds of a twin at rest.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import binom, chi2

from sins_sim.models.sensor_errors import sensor_params_from_dict
from sins_sim.navigation.alignment import align_coarse, mean_bias_wander_sigma
from sins_sim.navigation.attitude import attitude_error, quat_from_rotvec
from sins_sim.simulation.twin import gyro_wander_sigma, twin_increments

SEEDS = 60
#: The 99 % binomial interval of the count of seeds inside +-1.96 sigma when the sigma is right (p = 0.95).
COVERED = binom.interval(0.99, SEEDS, 0.95)


def _var_interval(n: int) -> tuple:
    """99.9 % chi-square interval of a sample variance over its true value, ``n - 1`` degrees of freedom."""
    return chi2.ppf(0.0005, n - 1) / (n - 1), chi2.ppf(0.9995, n - 1) / (n - 1)


def test_mean_of_a_random_walk_and_of_a_gauss_markov_process():
    rng = np.random.default_rng(5)
    m, n, dt = 4000, 400, 0.5
    t = n * dt
    k = 2e-7
    walks = np.cumsum(rng.standard_normal((m, n)) * k * math.sqrt(dt), axis=1)
    lo, hi = _var_interval(m)
    # the mean of the samples at dt, 2 dt, ..., T is the rectangle rule of (1 / T) int W: variance K^2 T / 3 times
    # (1 + 3 / (2 n) + 1 / (2 n^2)) (the discrete sum of min(i, j)), 0.4 % at n = 400: inside the interval's width
    ratio = walks.mean(axis=1).var(ddof=1) / mean_bias_wander_sigma(t, k) ** 2
    assert lo < ratio < hi * (1 + 1.5 / n)
    tau, q = 50.0, 4e-12
    phi = math.exp(-dt / tau)
    x = np.empty((m, n))
    x[:, 0] = rng.standard_normal(m) * math.sqrt(q)
    for i in range(1, n):                                           # the exact AR(1) of the process at dt
        x[:, i] = phi * x[:, i - 1] + rng.standard_normal(m) * math.sqrt(q * (1 - phi * phi))
    # the sample mean of the process at dt against the continuous mean: both x = T / tau = 4; the sampled one
    # differs by O(dt / tau) = 1 % (the rectangle rule of a function smooth at the scale tau), stated in the bound
    ratio = x.mean(axis=1).var(ddof=1) / mean_bias_wander_sigma(t, 0.0, [tau], [q]) ** 2
    assert lo * (1 - dt / tau) < ratio < hi * (1 + dt / tau)


def _coverage(with_wander: bool) -> int:
    site = {"lat_rad": math.radians(45.0), "lon_rad": 0.0, "height_m": 0.0}
    sens = sensor_params_from_dict({"gyro": {"arw_deg_rt_h": 0.002, "rrw_deg_h_rt_h": 0.05,
                                             "bias_instability_deg_h": 0.005},
                                    "accelerometer": {"vrw_ug_rt_hz": 5.0}}, "test")
    q = quat_from_rotvec(np.array([0.0, 0.0, 0.5]))
    dt, t_s = 0.01, 300.0
    n = int(t_s / dt)
    wander = gyro_wander_sigma(sens, t_s) if with_wander else 0.0
    inside = 0
    for seed in range(1, SEEDS + 1):
        _, dth, dv = twin_increments(sens, n, dt, site, q, seed)
        # no fixed bias in the twin: the priors are 0; the heading's error is then the wander's and the noise's
        al = align_coarse(dth, dv, dt, site["lat_rad"], gyro_bias_sigma_rad_s=0.0, accel_bias_sigma_m_s2=0.0,
                          gyro_wander_sigma_rad_s=wander)
        err = attitude_error(al.q_nb[None], q[None])[0]
        inside += abs(err[2]) < 1.96 * al.sigma_rad[2]
    return inside


def test_heading_sigma_covers_the_seeds_under_rate_random_walk():
    """With the wander the +-1.96 sigma heading interval holds the seeds' errors at its nominal 95 % (the count
    inside the 99 % binomial interval); without it (the block means' scatter alone) it does not."""
    inside = _coverage(True)
    assert COVERED[0] <= inside <= COVERED[1], inside
    assert _coverage(False) < COVERED[0]
