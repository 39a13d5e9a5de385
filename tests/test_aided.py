"""GNSS-aided navigation (issue 37): simulated fixes, the aided run, latency, outages, the RTS smoother.

The truth is the project's trajectory model (straight-and-level and turning flights at 100 m/s) with its
exact increments (``ideal_increments``), plus constant sensor biases and white noise drawn from the
filter's own ``ImuNoise`` (a tactical unit: 1 deg/h, 500 ug, ARW 0.05 deg/sqrt(h), VRW 50 ug/sqrt(Hz)),
initial errors drawn from ``P0`` and GNSS white noise of the stated sigmas, all from fixed seeds.
Increments at 20 Hz, fixes at 1 Hz, a few minutes per run.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.stats import chi2

from sins_sim import earth
from sins_sim.models.motion import CoordinatedTurn, Cruise, Trajectory
from sins_sim.navigation import ekf
from sins_sim.navigation.aided import navigate_aided, outage_growth, smooth
from sins_sim.navigation.attitude import dcm_from_quat, quat_from_rotvec, quat_multiply
from sins_sim.navigation.gnss import GnssSettings, simulate_gnss
from sins_sim.simulation.external import ideal_increments

LAT, LON, H = math.radians(45.0), math.radians(10.0), 1000.0
DT = 0.05
NOISE = ekf.ImuNoise.from_datasheet(0.05, 50.0, 1.0, 500.0)
P0 = ekf.initial_covariance(2.0, 0.1, 2e-4, 5e-3, NOISE)
GNSS_POS_SIGMA, GNSS_VEL_SIGMA = 2.0, 0.1
OUTAGE = (180.0, 300.0)
N_OUTAGE_SEEDS = 100
N_NEES_SEEDS = 50


class Flight:
    """A trajectory, its exact increments at 20 Hz and its truth at the increments' times and at 1 Hz."""

    def __init__(self, segments, duration_s):
        self.traj = Trajectory(LAT, LON, H, 100.0, math.radians(30.0), segments)
        self.n = int(round(duration_s / DT))
        self.t = DT * np.arange(1, self.n + 1)
        self.dth, self.dv = ideal_increments(self.traj, self.t)
        self.tt = np.concatenate([[0.0], self.t])
        self.truth = self.traj.evaluate(self.tt)
        self.out_t = np.arange(0.0, duration_s + 0.5, 1.0)
        self.out_truth = self.traj.evaluate(self.out_t)

    def fixes(self, settings, seed):
        tr = self.truth
        return simulate_gnss(self.tt, tr.lat_rad, tr.lon_rad, tr.h_m, tr.v_ned_m_s, settings, seed,
                             q_nb=tr.q_nv, omega_ib_b_rad_s=tr.omega_iv_v_rad_s)

    def run(self, seed, settings, noise_filter=NOISE, latency="compensate", output_t_s=None, told_lever=None,
            feedback=True):
        """One Monte Carlo run: biases, sensor noise, initial errors and GNSS noise from ``seed``; ``told_lever``
        replaces the lever arm the filter is given."""
        rng = np.random.default_rng(seed)
        bg = rng.normal(0.0, NOISE.gyro_bias_sigma_rad_s, 3)
        ba = rng.normal(0.0, NOISE.accel_bias_sigma_m_s2, 3)
        dth = self.dth + bg * DT + rng.normal(0.0, NOISE.gyro_arw_rad_sqrt_s * math.sqrt(DT), (self.n, 3))
        dv = self.dv + ba * DT + rng.normal(0.0, NOISE.accel_vrw_m_s_sqrt_s * math.sqrt(DT), (self.n, 3))
        x0 = rng.multivariate_normal(np.zeros(ekf.N_STATES), P0)
        start = inject(self.truth, x0, bg, ba)
        fixes = self.fixes(settings, rng)
        if told_lever is not None:
            fixes = dataclasses.replace(fixes, lever_arm_b_m=np.asarray(told_lever, dtype=float))
        res = navigate_aided(self.t, dth, dv, start, noise_filter, P0, fixes,
                             output_t_s=self.out_t if output_t_s is None else output_t_s, latency=latency,
                             feedback=feedback)
        return res

    def errors(self, sol):
        """Errors of a solution recorded at the 1 Hz output times (one epoch each, checked)."""
        assert np.allclose(sol.t_s, self.out_t, atol=1e-9)
        tr = self.out_truth
        return sol.errors(tr.lat_rad, tr.lon_rad, tr.h_m, tr.v_ned_m_s, tr.q_nv)


def inject(truth, x0, bg, ba):
    """The computed start: the truth at t = 0 with error ``x0`` (computed minus true), written from the
    state's definition independently of the module (``lat += dr_N/(R_N+h)``, ``lon += dr_E/((R_E+h) cos
    lat)``, ``h -= dr_D``, ``v += dv``, ``q = q(psi) (x) q``), bias estimates ``b + db``."""
    r_n, r_e = earth.radii(truth.lat_rad[0])
    lat, h = float(truth.lat_rad[0]), float(truth.h_m[0])
    return ekf.NavState(0.0, lat + x0[0] / (r_n + h), truth.lon_rad[0] + x0[1] / ((r_e + h) * math.cos(lat)),
                        h - x0[2], truth.v_ned_m_s[0] + x0[3:6], quat_multiply(quat_from_rotvec(x0[6:9]), truth.q_nv[0]),
                        bg + x0[9:12], ba + x0[12:15])


@pytest.fixture(scope="module")
def straight():
    return Flight([Cruise(300.0)], 300.0)


@pytest.fixture(scope="module")
def turning():
    return Flight([Cruise(30.0), CoordinatedTurn(60.0, math.pi), Cruise(30.0), CoordinatedTurn(60.0, -math.pi),
                   Cruise(60.0)], 240.0)


GNSS = GnssSettings(rate_hz=1.0, position_sigma_m=GNSS_POS_SIGMA, velocity_sigma_m_s=GNSS_VEL_SIGMA)


@pytest.fixture(scope="module")
def outage_mc(straight):
    """Straight and level, GNSS for 180 s, then a 120 s outage; N_OUTAGE_SEEDS runs, filtered and smoothed."""
    settings = GnssSettings(rate_hz=1.0, position_sigma_m=GNSS_POS_SIGMA, velocity_sigma_m_s=GNSS_VEL_SIGMA,
                            outages_s=[OUTAGE])
    runs = []
    for seed in range(N_OUTAGE_SEEDS):
        res = straight.run(500 + seed, settings)
        sm = smooth(res)
        err = straight.errors(res)
        runs.append((res, sm, err, straight.errors(sm)))
    return settings, runs


# --- the fixes ------------------------------------------------------------------------------------------------------


def test_gnss_fixes_noise_markov_latency_lever_arm_and_outages(straight):
    """Statistics of the simulated errors against their settings, the exact Gauss-Markov recursion, the two times,
    the lever arm in closed form, the outage windows and the seed."""
    tr = straight.truth
    lag = GnssSettings(rate_hz=2.0, position_sigma_m=(1.0, 2.0, 3.0), velocity_sigma_m_s=0.2, latency_s=0.25,
                       outages_s=[(100.0, 150.0)])
    fx = simulate_gnss(straight.tt, tr.lat_rad, tr.lon_rad, tr.h_m, tr.v_ned_m_s, lag, 11)
    assert np.all(fx.t_deliver_s - fx.t_valid_s == pytest.approx(0.25, abs=1e-12))
    assert not np.any((fx.t_valid_s >= 100.0) & (fx.t_valid_s < 150.0))
    assert len(fx) == 2 * 300 + 1 - 2 * 50
    # white noise, 501 independent samples: relative standard error of a std 1/sqrt(2 * 501) = 3.2 %, 4 of them
    assert np.all(np.abs(fx.position_error_ned_m.std(axis=0) / np.array([1.0, 2.0, 3.0]) - 1.0) < 0.13)
    # the Gauss-Markov part alone over a long record: its lag-1 correlation at the fix interval is exp(-dt/tau)
    gm_only = GnssSettings(rate_hz=2.0, position_sigma_m=1e-12, velocity_sigma_m_s=1e-12, markov_sigma_m=4.0,
                           markov_tau_s=10.0)
    long_t = np.arange(0.0, 20000.0, 0.5)
    z = np.zeros(long_t.size)
    e = simulate_gnss(long_t, z + LAT, z + LON, z, np.zeros((z.size, 3)), gm_only, 3).position_error_ned_m
    r1 = np.sum(e[1:] * e[:-1], axis=0) / np.sum(e * e, axis=0)
    rho, n = math.exp(-0.05), e.shape[0]
    # AR(1): the sample lag-1 correlation has the standard error sqrt((1 - rho^2) / N) = 0.0015; 4 of them
    assert np.all(np.abs(r1 - rho) < 4.0 * math.sqrt((1.0 - rho ** 2) / n)), r1
    # its variance: N_eff = N (1 - rho^2) / (1 + rho^2) = 2000, relative SE of the std 1/sqrt(2 N_eff) = 1.6 %; 4
    n_eff = n * (1.0 - rho ** 2) / (1.0 + rho ** 2)
    assert np.all(np.abs(e.std(axis=0) / 4.0 - 1.0) < 4.0 / math.sqrt(2.0 * n_eff)), e.std(axis=0)
    # white velocity noise, the same
    assert np.all(np.abs(fx.velocity_error_ned_m_s.std(axis=0) / 0.2 - 1.0) < 0.13)
    # reproducible from the seed
    again = simulate_gnss(straight.tt, tr.lat_rad, tr.lon_rad, tr.h_m, tr.v_ned_m_s, lag, 11)
    assert np.array_equal(again.lat_rad, fx.lat_rad) and np.array_equal(again.v_ned_m_s, fx.v_ned_m_s)
    # lever arm with no noise: antenna position r + C l, velocity v + C (w x l) - w_ie x C l
    lever = np.array([2.0, -1.0, -0.5])
    lv = GnssSettings(rate_hz=1.0, position_sigma_m=1e-12, velocity_sigma_m_s=1e-12, lever_arm_b_m=lever)
    turning_truth = Trajectory(LAT, LON, H, 100.0, 0.0, [CoordinatedTurn(20.0, 1.0)]).evaluate(np.arange(0.0, 20.5, 1.0))
    tr2 = turning_truth
    fl = simulate_gnss(tr2.t_s, tr2.lat_rad, tr2.lon_rad, tr2.h_m, tr2.v_ned_m_s, lv, 0, q_nb=tr2.q_nv,
                       omega_ib_b_rad_s=tr2.omega_iv_v_rad_s)
    k = 10                                            # mid-turn: banked, turning at 0.06 rad/s
    c = dcm_from_quat(tr2.q_nv[k])
    dn, de, _ = earth.horizontal_error_m(fl.lat_rad[k], fl.lon_rad[k], tr2.lat_rad[k], tr2.lon_rad[k], tr2.h_m[k])
    assert np.allclose([dn, de, -(fl.h_m[k] - tr2.h_m[k])], c @ lever, atol=1e-6)
    v_ant = tr2.v_ned_m_s[k] + c @ np.cross(tr2.omega_iv_v_rad_s[k], lever) - np.cross(earth.earth_rate_ned(
        tr2.lat_rad[k]), c @ lever)
    assert np.allclose(fl.v_ned_m_s[k], v_ant, atol=1e-9)
    assert np.linalg.norm(v_ant - tr2.v_ned_m_s[k]) > 0.1          # the lever arm term is there: 0.06 rad/s x 2.3 m


def test_gnss_settings_and_inputs_reject_bad_values_with_one_line():
    for kwargs, field in (({"rate_hz": 0.0}, "rate_hz"), ({"position_sigma_m": (1.0, -1.0, 1.0)}, "position_sigma_m"),
                          ({"velocity_sigma_m_s": 0.0}, "velocity_sigma_m_s"), ({"markov_tau_s": -1.0}, "markov_tau_s"),
                          ({"latency_s": -0.1}, "latency_s"), ({"lever_arm_b_m": (1.0, 2.0)}, "lever_arm_b_m"),
                          ({"outages_s": [(10.0, 5.0)]}, r"outages_s\[0\]")):
        with pytest.raises(ValueError, match=f"GnssSettings.{field}"):
            GnssSettings(**kwargs)
    t = np.arange(0.0, 10.0, 0.3)             # the 1 Hz validity times are not on this grid
    z = np.zeros(t.size)
    with pytest.raises(ValueError, match="t_s: must contain"):
        simulate_gnss(t, z, z, z, np.zeros((t.size, 3)), GnssSettings(), 0)
    with pytest.raises(ValueError, match="q_nb: required with a lever arm"):
        simulate_gnss(t[:1], z[:1], z[:1], z[:1], np.zeros((1, 3)), GnssSettings(lever_arm_b_m=(1, 0, 0)), 0)
    with pytest.raises(ValueError, match="seed"):
        simulate_gnss(t[:1], z[:1], z[:1], z[:1], np.zeros((1, 3)), GnssSettings(), -1)


# --- outage growth --------------------------------------------------------------------------------------------------


def test_outage_error_growth_matches_the_filter_covariance(outage_mc):
    """After 180 s of GNSS in straight and level flight, a 120 s outage. The RMS over N seeds of the horizontal
    error at 10, 30, 60, 120 s into it matches sqrt(P_NN + P_EE) of the covariance propagated from the last fix
    (the same for every seed to 1e-4: P does not depend on the data, up to the linearisation point).

    Tolerance: over n = 100 seeds the mean of e_N^2 + e_E^2 has a relative standard error at most sqrt(2/n)
    (equal when one axis dominates), the RMS half of it, 1/sqrt(2n) = 7.1 %; 20 % is 2.8 of them (two-sided
    0.5 % false alarm), and the linearisation error (relative psi + |dr|/R, 1e-3) is far below.
    """
    settings, runs = outage_mc
    growth = [outage_growth(res, settings.outages_s, errors=err)[0] for res, _, err, _ in runs]
    g0 = growth[0]
    assert g0.t_last_update_s == pytest.approx(179.0, abs=1e-9)
    assert np.allclose(g0.t_s, 179.0 + g0.after_s, atol=1e-9)
    pred = np.array([g.predicted_sigma_m for g in growth])
    assert np.all(np.abs(pred / pred[0] - 1.0) < 1e-3)
    rms = np.sqrt(np.mean(np.array([g.error_m for g in growth]) ** 2, axis=0))
    ratio = rms / pred[0]
    assert abs(ratio[2] - 1.0) < 0.2, (rms, pred[0])                    # 60 s: the asked check
    assert np.all(np.abs(ratio - 1.0) < 0.2), (rms, pred[0])            # and at 10, 30, 120 s
    # the outage's growth is the unaided one: 120 s gives far more than 60 s (gyro bias term ~ t^3)
    assert pred[0][3] > 3.0 * pred[0][2] > 3.0 * pred[0][1]


# --- smoother -------------------------------------------------------------------------------------------------------


def test_smoother_covariance_below_the_filter_and_its_error_below_in_the_outage(outage_mc):
    """The RTS covariance P_s = P+ + C (P_s(k+1) - P-(k+1)) C^T with P_s <= P- never exceeds the filter's (diagonal,
    every epoch, every state; 1e-9 relative for rounding); at the last epoch smoother and filter agree (s_K = 0:
    the correction of zero leaves the solution to rounding, 1e-12 rad and 1e-9 m/s); in the outage the smoother
    brings the fix after it back: the RMS horizontal error over the seeds falls below the filter's, and matches
    the smoother's own sigma within 20 % (the same standard error as the outage test, pooled over epochs)."""
    settings, runs = outage_mc
    res, sm, _, _ = runs[0]
    assert np.all(sm.sigma <= res.sigma * (1.0 + 1e-9) + 1e-300)
    assert np.max(sm.sigma[:-1, :2] / res.sigma[:-1, :2]) < 1.0
    assert np.allclose(sm.sigma[-1], res.sigma[-1], rtol=1e-12)
    assert np.all(sm.estimate[-1] == 0.0)
    assert abs(sm.lat_rad[-1] - res.lat_rad[-1]) < 1e-12 and abs(sm.lon_rad[-1] - res.lon_rad[-1]) < 1e-12
    assert np.allclose(sm.v_ned_m_s[-1], res.v_ned_m_s[-1], atol=1e-9)
    assert np.allclose(sm.q_nb[-1], res.q_nb[-1], atol=1e-12)
    inside = (res.t_s > OUTAGE[0]) & (res.t_s < OUTAGE[1])
    e_f = np.array([err[inside, :2] for _, _, err, _ in runs])
    e_s = np.array([errs[inside, :2] for _, _, _, errs in runs])
    rms_f = np.sqrt(np.mean(np.sum(e_f ** 2, axis=2)))
    rms_s = np.sqrt(np.mean(np.sum(e_s ** 2, axis=2)))
    sig_s = np.sqrt(np.mean(sm.sigma[inside, 0] ** 2 + sm.sigma[inside, 1] ** 2))
    assert rms_s < 0.5 * rms_f, (rms_s, rms_f)              # the smoother's sigma is 4x below the filter's here
    assert abs(rms_s / sig_s - 1.0) < 0.2, (rms_s, sig_s)


def test_closed_loop_smoother_equals_the_textbook_open_loop_one(turning):
    """The same seed through the closed loop and through the open loop (navigator free, error state accumulated,
    the textbook RTS on x; ``smooth`` serves both, module docstring). Both filters and both smoothers agree to
    first order: the open loop linearises about the free solution, whose error the run lets grow to ~25 m and
    1e-3 rad (b_g t = 4.8e-6 rad/s x 240 s); the neglected terms are that relative size, 1e-3, of errors of
    up to ~60 sigma of the aided solution, 0.07 sigma: every state within 0.1 sigma, including a 60 s outage."""
    settings = GnssSettings(rate_hz=1.0, position_sigma_m=GNSS_POS_SIGMA, velocity_sigma_m_s=GNSS_VEL_SIGMA,
                            outages_s=[(150.0, 210.0)])
    runs = {fb: turning.run(3, settings, feedback=fb) for fb in (True, False)}
    assert np.max(np.abs(runs[False].correction).sum(axis=0)[:2]) > 10.0        # the free error did grow
    for closed, open_ in ((runs[True], runs[False]), (smooth(runs[True]), smooth(runs[False]))):
        d = np.abs(turning.errors(closed) - turning.errors(open_)) / closed.sigma[:, :9]
        assert d.max() < 0.1, d.max(axis=0)


# --- consistency ----------------------------------------------------------------------------------------------------

CHECK_EVERY_S = 5


def _nees_mc(flight, noise_filter, seeds=N_NEES_SEEDS):
    """Per block (position, velocity, attitude) the NEES averaged over the seeds at every 5th epoch, the fraction of
    those epochs inside the chi-square 95 % interval (n * mean NEES ~ chi2(3 n)), and the runs."""
    nees = 0.0
    runs = []
    for seed in range(seeds):
        res = flight.run(2000 + seed, GNSS, noise_filter)
        err = flight.errors(res)[::CHECK_EVERY_S]
        p = res.p_upd[::CHECK_EVERY_S]
        nees = nees + np.stack([np.einsum("ki,ki->k", err[:, b], np.linalg.solve(p[:, b, b], err[:, b, None])[..., 0])
                                for b in (ekf.POS, ekf.VEL, ekf.ATT)], axis=1)
        runs.append(res)
    nees = nees / seeds
    lo, hi = chi2.ppf([0.025, 0.975], 3 * seeds) / seeds
    return np.mean((nees >= lo) & (nees <= hi), axis=0), nees, runs


@pytest.fixture(scope="module")
def nees_mc(turning):
    return _nees_mc(turning, NOISE)


def test_nees_consistent_in_a_turning_flight_and_a_mistuned_filter_fails(turning, nees_mc):
    """Two turns of 180 deg with GNSS at 1 Hz; 50 seeds drawn from the filter's own models. The averaged NEES of the
    position, velocity and attitude blocks lies in its chi-square 95 % interval at >= 90 % of the checked epochs
    (95 % expected; the epochs are correlated over tens of seconds, hence the margin). A filter told white sensor
    noises 10 times too small trusts its propagation: its attitude NEES leaves the interval at most epochs."""
    frac, nees, _ = nees_mc
    assert np.all(frac >= 0.9), (frac, np.median(nees, axis=0))
    frac_bad, nees_bad, _ = _nees_mc(turning, NOISE.scaled(0.1))
    assert frac_bad[2] <= 0.5, frac_bad
    assert np.median(nees_bad[:, 2]) > 1.3 * np.median(nees[:, 2])


def _lag1(z):
    """Lag-1 autocorrelation per column of a zero-mean sequence: sum z_k z_(k+1) / sum z_k^2."""
    return np.sum(z[1:] * z[:-1], axis=0) / np.sum(z * z, axis=0)


def test_innovations_white_and_nis_within_bounds(turning, nees_mc):
    """A consistent filter's innovations are white with covariance S. Per seed and axis the lag-1 autocorrelation of
    the normalised innovations is N(0, 1/M) (M = 241 fixes); its mean over 50 seeds is N(0, 1/(50 M)): within
    3/sqrt(50 M) = 0.027 (6 axes, 0.3 % false alarm each). The NIS (3 degrees of freedom) averaged over the
    seeds lies in its chi-square 95 % interval at >= 90 % of the epochs. An unmodelled Gauss-Markov position
    error (3 m, tau = 60 s) makes the position innovations correlated: over 5 seeds the same statistic lies
    three times beyond its bound (the test can fail)."""
    _, _, runs = nees_mc
    for name in ("position", "velocity"):
        z = np.array([r.normalised_innovations(name) for r in runs])           # (seeds, M, 3)
        r1 = np.mean([_lag1(zz) for zz in z], axis=0)
        bound = 3.0 / math.sqrt(z.shape[0] * z.shape[1])
        assert np.all(np.abs(r1) < bound), (name, r1, bound)
        nis = np.mean([r.nis[r.innovation_name == name] for r in runs], axis=0)
        lo, hi = chi2.ppf([0.025, 0.975], 3 * len(runs)) / len(runs)
        assert np.mean((nis >= lo) & (nis <= hi)) >= 0.9
    coloured = GnssSettings(rate_hz=1.0, position_sigma_m=GNSS_POS_SIGMA, velocity_sigma_m_s=GNSS_VEL_SIGMA,
                            markov_sigma_m=3.0, markov_tau_s=60.0)
    z = np.array([turning.run(3000 + s, coloured).normalised_innovations("position") for s in range(5)])
    r1 = np.mean([_lag1(zz) for zz in z], axis=0)
    assert np.all(r1[:2] > 3.0 * 3.0 / math.sqrt(z.shape[0] * z.shape[1])), r1       # 0.3 against 0.09


# --- latency --------------------------------------------------------------------------------------------------------


def test_latency_compensated_equals_zero_latency_and_ignoring_it_is_worse(turning):
    """Fixes delivered L = 0.4 s late, applied against the stored solution at their time of validity, give the
    solution of the same fixes without latency (compared at t_v + L, after both used the same fixes) to within
    the approximation's neglected term: the error's change over L, |dv| L, bounded by 4 sigma_v L with the
    filter's largest velocity sigma after the first 10 s (0.057 m/s): 9 cm. Applied as if current, each fix
    is displaced by the distance flown in L (40 m at 100 m/s) and the solution by a large part of it."""
    lat_s = 0.4
    out = np.arange(1.0, 240.0) + lat_s
    sol = {}
    for name, latency_s, mode in (("zero", 0.0, "compensate"), ("late", lat_s, "compensate"),
                                  ("naive", lat_s, "ignore")):
        settings = GnssSettings(rate_hz=1.0, position_sigma_m=GNSS_POS_SIGMA, velocity_sigma_m_s=GNSS_VEL_SIGMA,
                                latency_s=latency_s)
        res = turning.run(7, settings, latency=mode, output_t_s=out)
        keep = np.isin(np.round(res.t_s, 6), np.round(out, 6))
        tr = turning.traj.evaluate(res.t_s)
        sol[name] = (res, res.errors(tr.lat_rad, tr.lon_rad, tr.h_m, tr.v_ned_m_s, tr.q_nv)[keep])
    res0, e0 = sol["zero"]
    e_late, e_naive = sol["late"][1], sol["naive"][1]
    assert e0.shape == e_late.shape == (out.size, 9)
    assert np.all(sol["late"][0].t_valid_s[sol["late"][0].updated] + lat_s
                  == pytest.approx(sol["late"][0].t_s[sol["late"][0].updated], abs=1e-9))
    sigma_v = res0.sigma[res0.t_s > 10.0, 3:5].max()
    bound = 4.0 * sigma_v * lat_s
    d_late = np.hypot(*(e_late[10:, :2] - e0[10:, :2]).T)
    d_naive = np.hypot(*(e_naive[10:, :2] - e0[10:, :2]).T)
    assert d_late.max() < bound, (d_late.max(), bound)
    assert np.sqrt(np.mean(d_naive ** 2)) > 100.0 * bound, np.sqrt(np.mean(d_naive ** 2))


def test_lever_arm_is_carried_by_the_fixes_and_removed_by_the_filter(turning):
    """Fixes of an antenna 2.3 m from the IMU (2, -1, -0.5 m body) in the turning flight, same seed as a run with no
    lever arm: the filter's H removes it, and the two solutions differ only through the attitude error acting on
    the lever, below 4 sigma_psi0 |l| = 4 x 5e-3 x 2.3 m = 4.6 cm. Told no lever arm, the filter follows the
    antenna: off by the lever's horizontal length (2.2 m in level flight), more than half of it in RMS."""
    lever = np.array([2.0, -1.0, -0.5])
    with_lever = dataclasses.replace(GNSS, lever_arm_b_m=tuple(lever))
    e_none = turning.errors(turning.run(0, GNSS))
    e_lever = turning.errors(turning.run(0, with_lever))
    e_told_none = turning.errors(turning.run(0, with_lever, told_lever=np.zeros(3)))
    d = np.hypot(*(e_lever[10:, :2] - e_none[10:, :2]).T)
    assert d.max() < 4.0 * math.sqrt(P0[ekf.HEADING, ekf.HEADING]) * np.linalg.norm(lever), d.max()
    d_bad = np.hypot(*(e_told_none[10:, :2] - e_none[10:, :2]).T)
    assert np.sqrt(np.mean(d_bad ** 2)) > 0.5 * np.hypot(lever[0], lever[1])


# --- records and inputs ---------------------------------------------------------------------------------------------


def test_result_tables_and_bad_inputs(straight):
    res = straight.run(1, GNSS)
    df = res.to_pandas()
    assert df.shape[0] == len(res) and "sigma_dpos_n_m" in df and df.index.name == "t_s"
    inn = res.innovations_to_pandas()
    assert set(inn["name"]) == {"position", "velocity"} and len(inn) == 2 * int(res.updated.sum())
    assert smooth(res).to_pandas().shape == df.shape[:1] + (df.shape[1] - 2,)
    start = inject(straight.truth, np.zeros(15), np.zeros(3), np.zeros(3))
    fx = straight.fixes(GNSS, 0)
    with pytest.raises(ValueError, match="latency"):
        navigate_aided(straight.t, straight.dth, straight.dv, start, NOISE, P0, fx, latency="later")
    with pytest.raises(ValueError, match="use"):
        navigate_aided(straight.t, straight.dth, straight.dv, start, NOISE, P0, fx, use=("height",))
    with pytest.raises(ValueError, match="start.t_s"):
        navigate_aided(straight.t + 1.0, straight.dth, straight.dv, start, NOISE, P0, fx)
    with pytest.raises(ValueError, match="errors"):
        outage_growth(res, [(100.0, 120.0)], errors=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="lat_rad"):
        res.errors(np.zeros(2), np.zeros(2), np.zeros(2), np.zeros((2, 3)), np.zeros((2, 4)))
