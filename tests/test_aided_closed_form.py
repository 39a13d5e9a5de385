"""The outage error growth the aided filter predicts against the closed form of ``docs/theory/aided.md``.

Straight and level at 100 m/s (heading 30 deg, 45 deg N), a tactical unit (1 deg/h, 500 ug, ARW 0.05 deg/sqrt(h),
VRW 50 ug/sqrt(Hz)), GNSS at 1 Hz (2 m, 0.1 m/s) for 180 s, then a 120 s outage. From the filter's covariance after
the last fix, ``P+(t_a)``, the north and east position errors of the Pinson model without the Earth-rate coupling
of the two channels are linear in the state at t_a (Titterton & Weston 2004, ch. 12; Groves 2013, sec. 5.7)::

    dr_N(t) = dr_N + dv_N s1 - (g psi_E + a_N) s2 + g (e_E - Omega cos L psi_D) s3
    dr_E(t) = dr_E + dv_E s1 + (g psi_N - a_E) s2 - g e_N s3

with ``a = C db_a``, ``e = C db_g`` (NED), ``s1, s2, s3 = sin(w t)/w, (1 - cos w t)/w^2, (t - sin(w t)/w)/w^2``
(Schuler, ``w = sqrt(g/R)``) or their short-time forms ``t, t^2/2, t^3/6``, plus the white noises integrated over
the outage, ``S_a t^3/3 + g^2 S_g t^5/20`` per channel. The filter's own propagation (``outage_growth``) must
match it within what the closed form leaves out.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sins_sim import earth
from sins_sim.models.motion import Cruise, Trajectory
from sins_sim.navigation import ekf
from sins_sim.navigation.aided import navigate_aided, outage_growth
from sins_sim.navigation.attitude import dcm_from_quat
from sins_sim.navigation.gnss import GnssSettings, simulate_gnss
from sins_sim.simulation.external import ideal_increments

DT = 0.05
SPEED = 100.0
OUTAGE = (180.0, 300.0)
AFTER = np.array([10.0, 30.0, 60.0, 120.0])
NOISE = ekf.ImuNoise.from_datasheet(0.05, 50.0, 1.0, 500.0)
P0 = ekf.initial_covariance(2.0, 0.1, 2e-4, 5e-3, NOISE)


@pytest.fixture(scope="module")
def outage():
    """One run (biases and noise from a fixed seed; the covariance hardly depends on them), its last update before
    the outage and the predicted growth."""
    traj = Trajectory(math.radians(45.0), math.radians(10.0), 1000.0, SPEED, math.radians(30.0), [Cruise(300.0)])
    n = round(300.0 / DT)
    t = DT * np.arange(1, n + 1)
    dth, dv = ideal_increments(traj, t)
    tt = np.concatenate([[0.0], t])
    tr = traj.evaluate(tt)
    rng = np.random.default_rng(500)
    bg = rng.normal(0.0, NOISE.gyro_bias_sigma_rad_s, 3)
    ba = rng.normal(0.0, NOISE.accel_bias_sigma_m_s2, 3)
    dth = dth + bg * DT + rng.normal(0.0, NOISE.gyro_arw_rad_sqrt_s * math.sqrt(DT), (n, 3))
    dv = dv + ba * DT + rng.normal(0.0, NOISE.accel_vrw_m_s_sqrt_s * math.sqrt(DT), (n, 3))
    start = ekf.NavState(0.0, tr.lat_rad[0], tr.lon_rad[0], tr.h_m[0], tr.v_ned_m_s[0], tr.q_nv[0], np.zeros(3),
                         np.zeros(3))
    settings = GnssSettings(rate_hz=1.0, position_sigma_m=2.0, velocity_sigma_m_s=0.1, outages_s=[OUTAGE])
    fixes = simulate_gnss(tt, tr.lat_rad, tr.lon_rad, tr.h_m, tr.v_ned_m_s, settings, rng)
    res = navigate_aided(t, dth, dv, start, NOISE, P0, fixes, output_t_s=np.arange(0.0, 300.5, 1.0))
    growth = outage_growth(res, settings.outages_s, after_s=AFTER)[0]
    ka = int(np.flatnonzero(res.t_s == growth.t_last_update_s)[0])
    return res, ka, growth


def _earth(res, ka):
    """Gravity (m/s^2), the Gaussian mean radius plus height (m) and the Schuler frequency (rad/s) at epoch ``ka``."""
    lat, h = float(res.lat_rad[ka]), float(res.h_m[ka])
    g = float(earth.gravity_down(lat, h))
    r_n, r_e = earth.radii(lat)
    r = math.sqrt(r_n * r_e) + h
    return g, r, math.sqrt(g / r)


def _tolerance(res, ka, t):
    """(2 Omega + v/R) t: the relative size of the couplings the closed form leaves out (test docstring)."""
    _, r, _ = _earth(res, ka)
    return (2.0 * earth.EARTH_RATE_RAD_S + SPEED / r) * t


def _closed_form(res, ka, p, t, schuler: bool, noise=NOISE):
    """Horizontal 1-sigma (m) of the closed form at ``t`` s after epoch ``ka``, from the covariance ``p``."""
    lat = float(res.lat_rad[ka])
    c = dcm_from_quat(res.q_nb[ka])
    g, _, w = _earth(res, ka)
    if schuler:
        s1, s2, s3 = math.sin(w * t) / w, (1.0 - math.cos(w * t)) / w ** 2, (t - math.sin(w * t) / w) / w ** 2
    else:
        s1, s2, s3 = t, t * t / 2.0, t ** 3 / 6.0
    h_n, h_e = np.zeros(ekf.N_STATES), np.zeros(ekf.N_STATES)
    h_n[0], h_n[3], h_n[7], h_n[8] = 1.0, s1, -g * s2, -g * earth.EARTH_RATE_RAD_S * math.cos(lat) * s3
    h_n[ekf.ACCEL_BIAS], h_n[ekf.GYRO_BIAS] = -c[0] * s2, g * c[1] * s3
    h_e[1], h_e[4], h_e[6] = 1.0, s1, g * s2
    h_e[ekf.ACCEL_BIAS], h_e[ekf.GYRO_BIAS] = -c[1] * s2, -g * c[0] * s3
    white = noise.accel_vrw_m_s_sqrt_s ** 2 * t ** 3 / 3.0 + g * g * noise.gyro_arw_rad_sqrt_s ** 2 * t ** 5 / 20.0
    return math.sqrt(h_n @ p @ h_n + h_e @ p @ h_e + 2.0 * white)


def test_outage_growth_matches_the_pinson_closed_form(outage):
    """Tolerance at t into the outage: the closed form leaves out couplings of the two channels at the Coriolis rate
    2 Omega sin L (1.03e-4 rad/s), the Earth rate's other terms (<= Omega, 7.3e-5 rad/s) and the transport rate
    v/R (1.6e-5 rad/s), each a relative change first order in rate x t: (2 Omega + v/R) t, 1.9 % at 120 s, 0.16 %
    at 10 s. The short-time form departs from the Schuler one by (w t)^2/12 relative (0.2 % at 120 s), added."""
    res, ka, growth = outage
    p = res.p_upd[ka]
    assert growth.t_last_update_s == pytest.approx(179.0) and np.all(np.isfinite(growth.predicted_sigma_m))
    _, _, w = _earth(res, ka)
    for t, pred in zip(AFTER, growth.predicted_sigma_m):
        tol = _tolerance(res, ka, t)
        schuler = _closed_form(res, ka, p, t, schuler=True)
        short = _closed_form(res, ka, p, t, schuler=False)
        assert abs(schuler / pred - 1.0) < tol, (t, schuler, pred)
        assert abs(short / pred - 1.0) < tol + (w * t) ** 2 / 12.0, (t, short, pred)


def test_the_growth_needs_the_full_covariance_and_the_noise(outage):
    """The closed form discriminates: along a straight line the fixes see the tilt and the horizontal accelerometer
    bias only through g psi + a, so they leave the two anticorrelated; dropping the cross-covariances (the terms
    added as if independent) overstates the growth by far more than the tolerance above, and so does leaving out
    the white noise integrated over the outage (a third of the variance at 120 s)."""
    res, ka, growth = outage
    p = res.p_upd[ka]
    g, _, _ = _earth(res, ka)
    c = dcm_from_quat(res.q_nb[ka])
    sum_n = np.zeros(ekf.N_STATES)
    sum_n[7], sum_n[ekf.ACCEL_BIAS] = g, c[0]
    diag = np.diag(np.diag(p))
    # the combination is known three times better than the two parts added independently
    assert math.sqrt(sum_n @ p @ sum_n) < 0.5 * math.sqrt(sum_n @ diag @ sum_n)
    t, pred = AFTER[2], growth.predicted_sigma_m[2]
    assert _closed_form(res, ka, diag, t, schuler=True) / pred - 1.0 > 0.1
    quiet = _closed_form(res, ka, p, AFTER[3], schuler=True, noise=NOISE.scaled(0.0))
    assert 1.0 - quiet / growth.predicted_sigma_m[3] > 3.0 * _tolerance(res, ka, AFTER[3])
