"""Consistency of the aided filter at the mission level (issue 37, deliverable 5), with the mission's filter model.

The filter is told what :func:`~sins_sim.simulation.aiding.filter_model` tells it in a mission: the unit's white
noise and bias sigmas, the fixes' Gauss-Markov error as an equivalent white variance in ``R``, and the scale
factors and misalignments it does not estimate as equivalent white process noise from the vehicle's rates and
specific forces. The truth carries every one of those errors as the simulation draws them (not the filter's
white stand-ins): a Gauss-Markov sequence on the fixes, and per seed a constant scale-factor and misalignment
matrix on the gyros and the accelerometers. The navigation part of a mission runs on the trajectory's exact
increments (``ideal_increments``: the ideal dither filter's; the channel simulation would cost minutes per seed)
at 20 Hz, GNSS at 1 Hz, 120 s: 30 s of cruise, a 90-deg coordinated turn over 30 s, 60 s of cruise; 50 seeds.

The regime is the one the 15-state model holds in: a Gauss-Markov correlation (1 s) short against the aided
stretch, so that the equivalent white variance is close to exact after the first few fixes, and scale factors
and misalignments small enough that the equivalent white noise spread over the whole run stays close to the
truth in cruise and in the turn (:func:`~sins_sim.simulation.aiding.filter_model` states where it is
conservative: a Gauss-Markov correlation beyond the aided stretch, large errors in long turns).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.stats import chi2

from sins_sim import earth
from sins_sim.models.motion import CoordinatedTurn, Cruise, Trajectory
from sins_sim.models.sensor_errors import (
    AccelErrorParams,
    GyroErrorParams,
    SensorErrorParams,
)
from sins_sim.navigation import ekf
from sins_sim.navigation.aided import navigate_aided
from sins_sim.navigation.attitude import quat_from_rotvec, quat_multiply
from sins_sim.navigation.gnss import GnssSettings, simulate_gnss
from sins_sim.simulation.aiding import (
    AidingSettings,
    filter_model,
    markov_equivalent_sigma,
    unmodelled_densities,
)
from sins_sim.simulation.external import ideal_increments
from sins_sim.units import ARCSEC

LAT, LON, H = math.radians(52.0), math.radians(4.5), 300.0
DT = 0.05
DURATION_S = 120.0
N_SEEDS = 50
#: A tactical-grade unit, so that 60 s show its errors: 0.05 deg/sqrt(h), 50 ug/sqrt(Hz), 1 deg/h, 500 ug.
UNIT = ekf.ImuNoise.from_datasheet(0.05, 50.0, 1.0, 500.0)
#: Scale factors and misalignments (1-sigma, drawn per seed): 30 ppm / 6 arcsec gyros, 300 ppm / 20 arcsec
#: accelerometers. The accelerometers' times gravity (3 mg on the vertical axis) is six times their bias sigma:
#: the filter is consistent only with its bias prior raised by it.
SENSORS = SensorErrorParams(GyroErrorParams(scale_factor_ppm=30.0, misalignment_arcsec=[6.0] * 6),
                            AccelErrorParams(scale_factor_ppm=300.0, misalignment_arcsec=[20.0] * 6))
GNSS = GnssSettings(rate_hz=1.0, position_sigma_m=(0.5, 0.5, 1.0), velocity_sigma_m_s=(0.05, 0.05, 0.1),
                    markov_sigma_m=(1.0, 1.0, 2.0), markov_tau_s=1.0)
AIDING = AidingSettings(gnss=GNSS, update_rate_hz=1.0)
TILT0, HEADING0 = 2e-4, 5e-3
BLOCKS = (ekf.POS, ekf.VEL, ekf.ATT)


class Mission:
    """The trajectory, its exact increments and its truth at the 1 Hz output times."""

    def __init__(self):
        self.traj = Trajectory(LAT, LON, H, 60.0, math.radians(40.0),
                               [Cruise(30.0), CoordinatedTurn(30.0, math.pi / 2), Cruise(61.0)])
        self.n = round(DURATION_S / DT)
        self.t = DT * np.arange(1, self.n + 1)
        self.dth, self.dv = ideal_increments(self.traj, self.t)
        self.tt = np.concatenate([[0.0], self.t])
        self.truth = self.traj.evaluate(self.tt)
        self.out_t = np.arange(0.0, DURATION_S + 0.5, 1.0)
        self.out_truth = self.traj.evaluate(self.out_t)
        self.model = filter_model(AIDING, UNIT, SENSORS, self.traj, 0.0, DURATION_S)
        self.p0 = self.model.initial_covariance(np.hypot(GNSS.position_sigma_m, GNSS.markov_sigma_m),
                                                GNSS.velocity_sigma_m_s, TILT0, HEADING0)

    def run(self, seed, noise, pos_sigma, vel_sigma):
        """One seed: biases, noise, unit errors, initial errors and fixes drawn; the filter told the given model."""
        rng = np.random.default_rng([seed, 37])
        bg = rng.normal(0.0, UNIT.gyro_bias_sigma_rad_s, 3)
        ba = rng.normal(0.0, UNIT.accel_bias_sigma_m_s2, 3)
        k = {}
        for name, par in (("gyro", SENSORS.gyro), ("accel", SENSORS.accelerometer)):
            m = rng.normal(0.0, par.misalignment_arcsec[0] * ARCSEC, (3, 3))
            np.fill_diagonal(m, rng.normal(0.0, par.scale_factor_ppm[0] * 1e-6, 3))
            k[name] = np.eye(3) + m
        dth = self.dth @ k["gyro"].T + bg * DT + rng.normal(0.0, UNIT.gyro_arw_rad_sqrt_s * math.sqrt(DT), (self.n, 3))
        dv = self.dv @ k["accel"].T + ba * DT + rng.normal(0.0, UNIT.accel_vrw_m_s_sqrt_s * math.sqrt(DT), (self.n, 3))
        x0 = rng.multivariate_normal(np.zeros(ekf.N_STATES), self.p0)
        tr = self.truth
        r_n, r_e = earth.radii(tr.lat_rad[0])
        lat, h = float(tr.lat_rad[0]), float(tr.h_m[0])
        start = ekf.NavState(0.0, lat + x0[0] / (r_n + h), tr.lon_rad[0] + x0[1] / ((r_e + h) * math.cos(lat)),
                             h - x0[2], tr.v_ned_m_s[0] + x0[3:6], quat_multiply(quat_from_rotvec(x0[6:9]), tr.q_nv[0]),
                             bg + x0[9:12], ba + x0[12:15])
        fixes = simulate_gnss(self.tt, tr.lat_rad, tr.lon_rad, tr.h_m, tr.v_ned_m_s, GNSS, rng,
                              q_nb=tr.q_nv, omega_ib_b_rad_s=tr.omega_iv_v_rad_s)
        fixes = dataclasses.replace(fixes, position_sigma_m=np.asarray(pos_sigma, dtype=float),
                                    velocity_sigma_m_s=np.asarray(vel_sigma, dtype=float))
        res = navigate_aided(self.t, dth, dv, start, noise, self.p0, fixes, output_t_s=self.out_t)
        o = self.out_truth
        return res, res.errors(o.lat_rad, o.lon_rad, o.h_m, o.v_ned_m_s, o.q_nv)


def nees_mc(mission, noise, pos_sigma, vel_sigma, seeds=N_SEEDS):
    """Per block the NEES averaged over the seeds at every epoch after the start, and the fraction of epochs inside
    the 95 % interval of that average (``N * mean`` ~ chi2(3 N): chi2.ppf(0.025, 3 N) / N to
    chi2.ppf(0.975, 3 N) / N)."""
    total = 0.0
    for seed in range(seeds):
        res, err = mission.run(seed, noise, pos_sigma, vel_sigma)
        p = res.p_upd[1:]
        e = err[1:]
        total = total + np.stack([np.einsum("ki,ki->k", e[:, b], np.linalg.solve(p[:, b, b], e[:, b, None])[..., 0])
                                  for b in BLOCKS], axis=1)
    nees = total / seeds
    lo, hi = chi2.ppf([0.025, 0.975], 3 * seeds) / seeds
    return np.mean((nees >= lo) & (nees <= hi), axis=0), nees


@pytest.fixture(scope="module")
def mission():
    return Mission()


@pytest.mark.slow
def test_mission_filter_model_is_consistent_and_mistuned_ones_are_not(mission):
    """With the mission's model the seed-averaged NEES of position, velocity and attitude lies inside its 95 %
    interval (n = 50 seeds x 120 epochs) at >= 90 % of the epochs (95 % expected; neighbouring epochs are
    correlated over ~10 s, so the fraction itself scatters: 0.91 / 0.95 / 1.00 for these seeds, 0.80 to 0.98 for
    position over two further sets of 50). The same truth told only the unit's white noise and R = white +
    Gauss-Markov variance fails too (0.18 / 0.84 / 0.52). Told ``R / 10`` or ``Q / 10`` (white densities,
    including the unmodelled errors' equivalent), the filter trusts the fixes or its propagation too much and
    fails the same test."""
    m = mission.model
    frac, nees = nees_mc(mission, m.noise, m.position_sigma_m, m.velocity_sigma_m_s)
    assert np.all(frac >= 0.9), (frac, np.median(nees, axis=0))
    frac_r, _ = nees_mc(mission, m.noise, m.position_sigma_m / math.sqrt(10.0), m.velocity_sigma_m_s / math.sqrt(10.0))
    frac_q, _ = nees_mc(mission, m.noise.scaled(1.0 / math.sqrt(10.0)), m.position_sigma_m, m.velocity_sigma_m_s)
    assert np.min(frac_r) < 0.9 and np.min(frac_q) < 0.9, (frac_r, frac_q)
    frac_u, _ = nees_mc(mission, UNIT, np.hypot(GNSS.position_sigma_m, GNSS.markov_sigma_m), m.velocity_sigma_m_s)
    assert np.min(frac_u) < 0.9, frac_u


def test_markov_equivalent_variance_is_the_variance_of_the_mean():
    """``sigma_gm^2 g(n) / n`` against the direct sum of the Gauss-Markov autocovariance ``sigma^2 rho^|i-j|`` over
    an n x n grid (an independent computation: 1/n^2 sum_ij), to rounding; the white part adds as it is."""
    for tau, dt, n in ((300.0, 0.2, 495), (1.0, 1.0, 120), (20.0, 1.0, 7)):
        rho = math.exp(-dt / tau)
        i = np.arange(n)
        direct = np.sum(rho ** np.abs(i[:, None] - i[None, :])) / n ** 2
        got = markov_equivalent_sigma([0.3] * 3, [1.5] * 3, tau, dt, n)
        assert np.allclose((got ** 2 - 0.09) / n, 2.25 * direct, rtol=1e-9, atol=0.0), (tau, n)


def test_unmodelled_density_of_a_turn_is_sigma_squared_omega_squared_duration():
    """A level 90-deg turn between two cruises: the gyro density ``sigma_K^2 max_W |delta theta_W|^2 / W`` is at
    least the turn's ``sigma_K^2 (pi/2)^2 / 30 s`` and at most that over the turn's constant-rate part (the
    trajectory's roll-in and roll-out, 5 s each: 20 s) with a 25 % allowance for the bank's roll rates; an aircraft
    at rest gets none."""
    traj = Trajectory(LAT, LON, H, 60.0, 0.0, [Cruise(20.0), CoordinatedTurn(30.0, math.pi / 2), Cruise(31.0)])
    d = unmodelled_densities(SENSORS, traj, 0.0, 80.0, step_s=0.1)   # cruise most of the span: its median
    k = 30e-6                                               # max(scale factor, misalignment 6 arcsec = 29 ppm)
    assert d["gyro_k"] == pytest.approx(k)
    # the heading change alone over the turn's duration: (pi/2)^2 / 30 (the roll in and out and Earth rate add
    # a little: at most the bank's roll rate, 17 deg, about 5 % of pi/2, each way)
    assert k * k * (math.pi / 2) ** 2 / 30.0 <= d["gyro_rad2_s"] <= 1.25 * k * k * (math.pi / 2) ** 2 / 20.0
    at_rest = unmodelled_densities(SENSORS, Trajectory(LAT, LON, H, 0.0, 0.0, [Cruise(60.0)]), 0.0, 50.0)
    assert at_rest["gyro_rad2_s"] < 1e-6 * d["gyro_rad2_s"] and at_rest["accel_m2_s3"] < 1e-12
